// The board's pose in one camera frame (docs/tracking.md "Pose per frame").
//
// 1. Markers are found by OpenCV's ArUco detector on the frame at half size (a quarter of the
//    pixels); when that finds fewer than three board markers (a far or steep board whose cells are
//    too small at half size), the search is repeated at full resolution (at twice the size
//    when the region is small) inside a region of interest: around the board's predicted place
//    when a previous pose is given, else around the markers and square candidates the half-size
//    pass saw, else the whole frame.
// 2. Every marker's corners are refined at full resolution by edge-line fits (edge_refine.hpp),
//    in undistorted pixels.
// 3. The pose: IPPE (cv::SOLVEPNP_IPPE, planar, both solutions), then Levenberg-Marquardt on all
//    corners. Markers the search missed are then looked for where this pose puts them (their
//    edges refined the same way) and the pose is refined on all. When the two IPPE solutions fit
//    almost equally well (the planar ambiguity of a small or far board), both predict markers
//    and the one whose markers are found wins; if the two still fit alike with every marker,
//    the one closer to the previous pose is taken, or, without one, the frame is rejected.
//    Markers whose corners fit badly are dropped and the pose solved again.
// 4. Quality: reprojection RMS (pixels) and markers used. Rejected: fewer than `min_markers`
//    markers, RMS above `max_rms_px`, ambiguous.
#pragma once

#include <opencv2/aruco.hpp>
#include <optional>
#include <string>

#include "appliance/tracking/board.hpp"
#include "appliance/tracking/camera.hpp"

namespace glint::tracking {

struct DetectorOptions {
    int min_markers = 3;
    double max_rms_px = 1.0;
    // Ambiguous when the second IPPE solution's reprojection RMS is below ratio x the first's ...
    double ambiguity_ratio = 1.5;
    double ambiguity_margin_px = 0.05;  // ... plus this much (noise makes tiny errors alike)
    bool edge_refinement = true;  // false: ArUco alone at full size, CORNER_REFINE_SUBPIX (for comparison)
    // The search is done when it has this many markers (the pose from them predicts the rest);
    // a pose needs `min_markers`.
    int min_search_markers = 3;
    // Look for the markers the search missed where the first pose puts them.
    bool predicted_markers = true;
};

struct Detection {
    bool detected = false;
    Pose pose;                // camera_from_board (valid when detected)
    double rms_px = 0;        // reprojection RMS of the corners used
    int markers = 0;          // markers used in the pose
    int markers_found = 0;    // board markers the detector found
    int markers_refined = 0;  // of those, with four clear edges
    int markers_predicted = 0;  // found where the first pose put them
    bool full_resolution_search = false;  // the half-size pass was not enough
    std::string rejection;    // why not detected ("" when detected)
    // Where the time went, milliseconds: marker search (both passes), corner refinement, pose.
    double search_ms = 0, refine_ms = 0, pose_ms = 0;
};

class Detector {
public:
    // `board` must outlive the detector (it is kept by reference).
    Detector(const Board& board, const Camera& camera, DetectorOptions options = {});
    // `gray`: 8-bit single channel, camera.width x camera.height. `prior`: the previous pose of
    // a sequence, for the region of interest and the ambiguity.
    Detection detect(const cv::Mat& gray, const std::optional<Pose>& prior = std::nullopt) const;

    struct Found {
        std::vector<std::vector<cv::Point2f>> corners;  // full-size pixels
        std::vector<int> ids;
    };

private:
    Found search(const cv::Mat& gray, const std::optional<Pose>& prior, Detection& result) const;

    const Board& board_;
    Camera camera_;
    DetectorOptions options_;
    cv::Ptr<cv::aruco::DetectorParameters> half_params_, full_params_;
};

}  // namespace glint::tracking
