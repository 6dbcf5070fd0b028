// Per-frame tracking of the board (docs/tracking.md): detection -> One Euro filter while the
// board is seen; the orientation-sensor bridge and the fade-out while it is not.
#pragma once

#include <optional>

#include "appliance/tracking/detector.hpp"
#include "appliance/tracking/dropout_bridge.hpp"
#include "appliance/tracking/pose_filter.hpp"

namespace glint::tracking {

struct TrackerOptions {
    DetectorOptions detector;
    PoseFilterParams filter;
    double hold_s = 0.5, fade_s = 0.25;
    // A detection after a gap longer than this restarts the filter (no smoothing across a jump).
    double filter_restart_gap_s = 0.15;
};

struct TrackResult {
    bool detected = false;     // the board was found in this frame
    bool has_pose = false;     // a pose to draw with (detected, or bridged)
    Pose pose;                 // camera_from_board: filtered when detected, bridged otherwise
    double visibility = 0;     // 1 when detected, 1..0 through a dropout
    bool from_sensor = false;  // bridged by the orientation sensor
    Detection detection;       // the frame's raw detection (quality figures)
};

class Tracker {
public:
    // `board` must outlive the tracker.
    Tracker(const Board& board, const Camera& camera, const glm::dquat& sensor_from_camera,
            TrackerOptions options = {});
    void add_orientation(const OrientationSample& sample) { bridge_.add_orientation(sample); }
    TrackResult track(double t, const cv::Mat& gray);

private:
    Detector detector_;
    PoseFilter filter_;
    DropoutBridge bridge_;
    TrackerOptions options_;
    std::optional<double> last_detection_t_;
    std::optional<Pose> last_pose_;
};

}  // namespace glint::tracking
