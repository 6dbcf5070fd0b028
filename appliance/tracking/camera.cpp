#include "appliance/tracking/camera.hpp"

#include <cmath>
#include <numbers>
#include <opencv2/calib3d.hpp>

namespace glint::tracking {

Camera Camera::from_fov(int width, int height, double horizontal_fov_deg) {
    Camera c;
    c.width = width;
    c.height = height;
    c.fx = c.fy = 0.5 * width / std::tan(0.5 * horizontal_fov_deg * std::numbers::pi / 180);
    c.cx = 0.5 * (width - 1);
    c.cy = 0.5 * (height - 1);
    return c;
}

Pose Pose::inverse() const {
    const glm::dquat r = glm::conjugate(rotation);
    return {r, -(r * translation)};
}

Pose operator*(const Pose& a, const Pose& b) {
    return {unit_rotation(a.rotation * b.rotation), a.rotation * b.translation + a.translation};
}

Pose pose_from_rvec_tvec(const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
    return {rotation_from_vector({rvec[0], rvec[1], rvec[2]}), {tvec[0], tvec[1], tvec[2]}};
}

void pose_to_rvec_tvec(const Pose& pose, cv::Vec3d& rvec, cv::Vec3d& tvec) {
    const glm::dvec3 r = rotation_vector(pose.rotation);
    rvec = {r.x, r.y, r.z};
    tvec = {pose.translation.x, pose.translation.y, pose.translation.z};
}

Pose view_pose(double distance, double tilt_deg, double azimuth_deg, double roll_deg, cv::Vec2d offset) {
    const double deg = std::numbers::pi / 180;
    // Camera looking straight at the board: camera +Z = board -Z, camera +X = board +X, camera
    // +Y (down) = board -Y. Then the board is turned about an in-plane axis (tilt) and the
    // camera rolled about its optical axis.
    const glm::dquat facing = glm::angleAxis(std::numbers::pi, glm::dvec3(1, 0, 0));
    const glm::dvec3 tilt_axis(std::cos(azimuth_deg * deg), std::sin(azimuth_deg * deg), 0);
    const glm::dquat tilt = glm::angleAxis(tilt_deg * deg, tilt_axis);
    const glm::dquat roll = glm::angleAxis(roll_deg * deg, glm::dvec3(0, 0, 1));
    Pose p;
    p.rotation = unit_rotation(roll * facing * tilt);
    const glm::dvec3 dir = glm::normalize(glm::dvec3(offset[0], offset[1], 1));
    p.translation = dir * distance;
    return p;
}

double rotation_error_deg(const Pose& estimate, const Pose& truth) {
    return angle_between(unit_rotation(estimate.rotation), unit_rotation(truth.rotation)) * 180 / std::numbers::pi;
}

double translation_error_fraction(const Pose& estimate, const Pose& truth) {
    return glm::length(estimate.translation - truth.translation) / glm::length(truth.translation);
}

}  // namespace glint::tracking
