#include "appliance/tracking/detector.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "appliance/core/errors.hpp"
#include "appliance/tracking/edge_refine.hpp"

namespace glint::tracking {
namespace {

struct Found {
    std::vector<std::vector<cv::Point2f>> corners;
    std::vector<int> ids;
};

// Board markers only, each id once.
void keep_board_markers(const Board& board, Found& f) {
    Found kept;
    std::vector<bool> seen(std::size_t(board.marker_count()), false);
    for (std::size_t i = 0; i < f.ids.size(); ++i) {
        const int index = board.index_of(f.ids[i]);
        if (index < 0 || seen[std::size_t(index)]) continue;
        seen[std::size_t(index)] = true;
        kept.ids.push_back(f.ids[i]);
        kept.corners.push_back(f.corners[i]);
    }
    f = std::move(kept);
}

cv::Rect clamp_rect(cv::Rect r, const cv::Size& size) { return r & cv::Rect(0, 0, size.width, size.height); }

// The image bounding box of the board (its markers' outer corners) at `pose`, or empty.
cv::Rect predicted_board_box(const Board& board, const Camera& camera, const Pose& pose) {
    std::vector<cv::Point3f> object;
    for (int i = 0; i < board.marker_count(); ++i)
        for (const cv::Point3f& p : board.corners(i)) object.push_back(p);
    cv::Vec3d rvec, tvec;
    pose_to_rvec_tvec(pose, rvec, tvec);
    if (tvec[2] <= 0) return {};
    std::vector<cv::Point2f> image;
    cv::projectPoints(object, rvec, tvec, camera.matrix(), camera.distortion(), image);
    return cv::boundingRect(image);
}

struct Solution {
    cv::Vec3d rvec, tvec;
    double rms = 0;
};

double reprojection_rms(const std::vector<cv::Point3d>& object, const std::vector<cv::Point2d>& image,
                        const cv::Matx33d& k, const cv::Vec3d& rvec, const cv::Vec3d& tvec,
                        std::vector<double>* per_point = nullptr) {
    std::vector<cv::Point2d> projected;
    cv::projectPoints(object, rvec, tvec, k, cv::noArray(), projected);
    double sum = 0;
    if (per_point) per_point->resize(image.size());
    for (std::size_t i = 0; i < image.size(); ++i) {
        const double e2 = (projected[i].x - image[i].x) * (projected[i].x - image[i].x) +
                          (projected[i].y - image[i].y) * (projected[i].y - image[i].y);
        sum += e2;
        if (per_point) (*per_point)[i] = e2;
    }
    return std::sqrt(sum / double(std::max<std::size_t>(1, image.size())));
}

}  // namespace

Detector::Detector(const Board& board, const Camera& camera, DetectorOptions options)
    : board_(board), camera_(camera), options_(options) {
    if (camera.width < 16 || camera.height < 16 || !(camera.fx > 0) || !(camera.fy > 0))
        throw InputError("tracking: the camera's intrinsics are unusable (size or focal length)");
    half_params_ = cv::aruco::DetectorParameters::create();
    half_params_->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;
    full_params_ = cv::aruco::DetectorParameters::create();
    full_params_->cornerRefinementMethod =
        options.edge_refinement ? cv::aruco::CORNER_REFINE_NONE : cv::aruco::CORNER_REFINE_SUBPIX;
}

Detection Detector::detect(const cv::Mat& gray, const std::optional<Pose>& prior) const {
    if (gray.type() != CV_8UC1 || gray.cols != camera_.width || gray.rows != camera_.height)
        throw InputError("tracking: a frame of " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                         " does not match the calibration's " + std::to_string(camera_.width) + "x" +
                         std::to_string(camera_.height) + " (or is not 8-bit grey)");
    Detection result;
    Found found;
    std::vector<std::vector<cv::Point2f>> candidates;
    if (options_.edge_refinement) {
        cv::Mat half;
        cv::resize(gray, half, cv::Size(gray.cols / 2, gray.rows / 2), 0, 0, cv::INTER_AREA);
        cv::aruco::detectMarkers(half, board_.dictionary(), found.corners, found.ids, half_params_, candidates);
        keep_board_markers(board_, found);
        // Half-size pixel centre i is full-size coordinate 2 i + 0.5.
        for (auto& marker : found.corners)
            for (cv::Point2f& p : marker) p = 2.0f * p + cv::Point2f(0.5f, 0.5f);
    }
    if (int(found.ids.size()) < options_.min_markers) {
        // The full-resolution search, in the smallest region that can hold the board.
        cv::Rect roi(0, 0, gray.cols, gray.rows);
        if (options_.edge_refinement) {
            cv::Rect box;
            if (prior) box = predicted_board_box(board_, camera_, *prior);
            if (box.empty()) {
                for (const auto& marker : found.corners) box |= cv::boundingRect(marker);
                for (const auto& c : candidates) {
                    std::vector<cv::Point2f> scaled;
                    for (const cv::Point2f& p : c) scaled.push_back(2.0f * p + cv::Point2f(0.5f, 0.5f));
                    box |= cv::boundingRect(scaled);
                }
            }
            if (!box.empty()) {
                const int pad = std::max(box.width, box.height) / 2 + 16;
                roi = clamp_rect(cv::Rect(box.x - pad, box.y - pad, box.width + 2 * pad, box.height + 2 * pad),
                                 gray.size());
            }
        }
        result.full_resolution_search = true;
        Found full;
        cv::aruco::detectMarkers(gray(roi), board_.dictionary(), full.corners, full.ids, full_params_);
        keep_board_markers(board_, full);
        for (auto& marker : full.corners)
            for (cv::Point2f& p : marker) p += cv::Point2f(float(roi.x), float(roi.y));
        if (full.ids.size() > found.ids.size()) found = std::move(full);
    }
    result.markers_found = int(found.ids.size());
    if (result.markers_found < options_.min_markers) {
        result.rejection = "too few markers (" + std::to_string(result.markers_found) + ")";
        return result;
    }

    // Corners: refined and undistorted, grouped by marker.
    std::vector<int> marker_index;
    std::vector<std::array<cv::Point2d, 4>> image_corners;
    for (std::size_t i = 0; i < found.ids.size(); ++i) {
        std::array<cv::Point2d, 4> u;
        if (options_.edge_refinement) {
            const std::array<cv::Point2f, 4> c{found.corners[i][0], found.corners[i][1], found.corners[i][2],
                                               found.corners[i][3]};
            if (!refine_marker_corners(gray, camera_, c, u)) continue;
        } else {
            const std::vector<cv::Point2d> d(found.corners[i].begin(), found.corners[i].end());
            const std::vector<cv::Point2d> und = undistort_pixels(camera_, d);
            std::copy(und.begin(), und.end(), u.begin());
        }
        marker_index.push_back(board_.index_of(found.ids[i]));
        image_corners.push_back(u);
    }
    const cv::Matx33d k = camera_.matrix();
    std::vector<cv::Point3d> object;
    std::vector<cv::Point2d> image;
    const auto gather = [&](const std::vector<bool>& use) {
        object.clear();
        image.clear();
        for (std::size_t m = 0; m < marker_index.size(); ++m) {
            if (!use[m]) continue;
            for (int c = 0; c < 4; ++c) {
                object.push_back(board_.corners(marker_index[m])[c]);
                image.push_back(image_corners[m][c]);
            }
        }
    };
    std::vector<bool> use(marker_index.size(), true);
    gather(use);
    if (int(marker_index.size()) < options_.min_markers) {
        result.rejection = "too few markers with clear edges (" + std::to_string(marker_index.size()) + ")";
        return result;
    }
    std::vector<cv::Mat> rvecs, tvecs;
    std::vector<double> errors;
    cv::solvePnPGeneric(object, image, k, cv::noArray(), rvecs, tvecs, false, cv::SOLVEPNP_IPPE, cv::noArray(),
                        cv::noArray(), errors);
    if (rvecs.empty()) {
        result.rejection = "no pose";
        return result;
    }
    std::vector<Solution> solutions;
    for (std::size_t i = 0; i < rvecs.size(); ++i) {
        Solution s{cv::Vec3d(rvecs[i]), cv::Vec3d(tvecs[i]), 0};
        cv::solvePnPRefineLM(object, image, k, cv::noArray(), s.rvec, s.tvec);
        s.rms = reprojection_rms(object, image, k, s.rvec, s.tvec);
        solutions.push_back(s);
    }
    std::sort(solutions.begin(), solutions.end(), [](const Solution& a, const Solution& b) { return a.rms < b.rms; });
    Solution chosen = solutions[0];
    // Both IPPE solutions may refine to the same pose (then there is no ambiguity).
    const bool distinct = solutions.size() > 1 &&
                          rotation_error_deg(pose_from_rvec_tvec(solutions[0].rvec, solutions[0].tvec),
                                             pose_from_rvec_tvec(solutions[1].rvec, solutions[1].tvec)) > 0.5;
    if (distinct && solutions[1].rms < options_.ambiguity_ratio * solutions[0].rms + options_.ambiguity_margin_px) {
        if (!prior) {
            result.rejection = "ambiguous pose (the two IPPE solutions fit alike)";
            return result;
        }
        const double a0 = rotation_error_deg(pose_from_rvec_tvec(solutions[0].rvec, solutions[0].tvec), *prior);
        const double a1 = rotation_error_deg(pose_from_rvec_tvec(solutions[1].rvec, solutions[1].tvec), *prior);
        if (a1 < a0) chosen = solutions[1];
    }
    // Drop markers whose corners fit badly (a corner pulled by an occluder), solve again.
    std::vector<double> e2;
    reprojection_rms(object, image, k, chosen.rvec, chosen.tvec, &e2);
    std::vector<double> marker_rms;
    for (std::size_t m = 0; m < marker_index.size(); ++m)
        marker_rms.push_back(std::sqrt(0.25 * (e2[4 * m] + e2[4 * m + 1] + e2[4 * m + 2] + e2[4 * m + 3])));
    std::vector<double> sorted = marker_rms;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double limit = std::max(0.5, 4 * sorted[sorted.size() / 2]);
    int dropped = 0;
    for (std::size_t m = 0; m < marker_index.size(); ++m)
        if (marker_rms[m] > limit) use[m] = false, ++dropped;
    if (dropped > 0) {
        gather(use);
        if (int(marker_index.size()) - dropped < options_.min_markers) {
            result.rejection = "too few markers fit the pose";
            return result;
        }
        cv::solvePnPRefineLM(object, image, k, cv::noArray(), chosen.rvec, chosen.tvec);
        chosen.rms = reprojection_rms(object, image, k, chosen.rvec, chosen.tvec);
    }
    result.markers = int(marker_index.size()) - dropped;
    result.rms_px = chosen.rms;
    result.pose = pose_from_rvec_tvec(chosen.rvec, chosen.tvec);
    if (chosen.rms > options_.max_rms_px) {
        result.rejection = "reprojection RMS " + std::to_string(chosen.rms) + " px above the limit";
        return result;
    }
    if (chosen.tvec[2] <= 0) {
        result.rejection = "board behind the camera";
        return result;
    }
    result.detected = true;
    return result;
}

}  // namespace glint::tracking
