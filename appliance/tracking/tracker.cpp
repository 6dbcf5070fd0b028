#include "appliance/tracking/tracker.hpp"

namespace glint::tracking {

Tracker::Tracker(const Board& board, const Camera& camera, const glm::dquat& sensor_from_camera,
                 TrackerOptions options)
    : detector_(board, camera, options.detector),
      filter_(options.filter),
      bridge_(sensor_from_camera, options.hold_s, options.fade_s),
      options_(options) {}

TrackResult Tracker::track(double t, const cv::Mat& gray) {
    TrackResult r;
    r.detection = detector_.detect(gray, last_pose_);
    if (r.detection.detected) {
        if (last_detection_t_ && t - *last_detection_t_ > options_.filter_restart_gap_s) filter_.reset();
        r.detected = r.has_pose = true;
        r.pose = filter_.update(t, r.detection.pose);
        r.visibility = 1;
        bridge_.on_detection(t, r.pose);
        last_detection_t_ = t;
        last_pose_ = r.pose;
        return r;
    }
    if (const auto b = bridge_.bridge(t)) {
        r.has_pose = true;
        r.pose = b->pose;
        r.visibility = b->visibility;
        r.from_sensor = b->from_sensor;
        last_pose_ = b->pose;
    } else {
        last_pose_.reset();
    }
    return r;
}

}  // namespace glint::tracking
