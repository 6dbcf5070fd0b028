#include "appliance/tracking/dropout_bridge.hpp"

#include <algorithm>

namespace glint::tracking {

DropoutBridge::DropoutBridge(const glm::dquat& sensor_from_camera, double hold_s, double fade_s)
    : sensor_from_camera_(unit_rotation(sensor_from_camera)), hold_s_(hold_s), fade_s_(fade_s) {}

void DropoutBridge::add_orientation(const OrientationSample& sample) {
    if (!samples_.empty() && sample.t <= samples_.back().t) return;
    samples_.push_back({sample.t, unit_rotation(sample.world_from_sensor)});
    // Keep a few seconds: enough for any frame still to come.
    while (samples_.size() > 2 && samples_.front().t < sample.t - 5.0) samples_.pop_front();
}

std::optional<glm::dquat> DropoutBridge::orientation_at(double t) const {
    if (samples_.empty() || t < samples_.front().t || t > samples_.back().t) return std::nullopt;
    const auto after = std::lower_bound(samples_.begin(), samples_.end(), t,
                                        [](const OrientationSample& s, double v) { return s.t < v; });
    if (after == samples_.begin()) return after->world_from_sensor;
    const auto before = after - 1;
    const double f = (t - before->t) / (after->t - before->t);
    return unit_rotation(glm::slerp(before->world_from_sensor, after->world_from_sensor, f));
}

void DropoutBridge::on_detection(double t, const Pose& camera_from_board) {
    last_t_ = t;
    last_pose_ = camera_from_board;
    world_from_camera_at_last_.reset();
    if (const auto ws = orientation_at(t)) world_from_camera_at_last_ = unit_rotation(*ws * sensor_from_camera_);
}

std::optional<BridgedPose> DropoutBridge::bridge(double t) const {
    if (!last_t_) return std::nullopt;
    const double gap = t - *last_t_;
    if (gap < 0 || gap >= hold_s_ + fade_s_) return std::nullopt;
    BridgedPose b;
    b.visibility = gap <= hold_s_ ? 1.0 : 1.0 - (gap - hold_s_) / fade_s_;
    b.pose = last_pose_;
    const auto ws = orientation_at(t);
    if (world_from_camera_at_last_ && ws) {
        // camera(t)_from_camera(t0) = (world_from_camera(t))^-1 * world_from_camera(t0).
        const glm::dquat world_from_camera = unit_rotation(*ws * sensor_from_camera_);
        const glm::dquat relative = unit_rotation(glm::conjugate(world_from_camera) * *world_from_camera_at_last_);
        b.pose = Pose{relative, glm::dvec3(0)} * last_pose_;
        b.from_sensor = true;
    }
    return b;
}

}  // namespace glint::tracking
