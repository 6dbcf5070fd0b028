// The camera as tracking sees it, and the pose it reports.
//
// Frames (docs/tracking.md): the camera frame is OpenCV's (+X right, +Y down, +Z forward), the
// board frame the printed board's (origin at its centre, +X right, +Y up, +Z out of the printed
// side), units metres. A Pose is camera_from_board: x_camera = rotation * x_board + translation.
// Tracking keeps its own intrinsics type (the capture module's calibration file is read by the
// app layer and converted), so it depends on core and OpenCV only.
#pragma once

#include <opencv2/core.hpp>

#include "appliance/core/rotation.hpp"

namespace glint::tracking {

struct Camera {
    int width = 0, height = 0;     // pixels
    double fx = 0, fy = 0, cx = 0, cy = 0;
    double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;  // OpenCV's radial-tangential distortion

    cv::Matx33d matrix() const { return {fx, 0, cx, 0, fy, cy, 0, 0, 1}; }
    cv::Mat distortion() const { return (cv::Mat_<double>(1, 5) << k1, k2, p1, p2, k3); }
    bool distorted() const { return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0; }
    // A distortion-free camera of the given horizontal field of view, principal point centred.
    static Camera from_fov(int width, int height, double horizontal_fov_deg);
};

struct Pose {
    glm::dquat rotation{1, 0, 0, 0};
    glm::dvec3 translation{0};

    glm::dvec3 apply(const glm::dvec3& p) const { return rotation * p + translation; }
    Pose inverse() const;
};
Pose operator*(const Pose& a, const Pose& b);  // a after b

// OpenCV's rvec/tvec <-> Pose.
Pose pose_from_rvec_tvec(const cv::Vec3d& rvec, const cv::Vec3d& tvec);
void pose_to_rvec_tvec(const Pose& pose, cv::Vec3d& rvec, cv::Vec3d& tvec);

// A board pose looking at the board from `distance` metres along a direction tilted by
// `tilt_deg` from the board's normal (towards azimuth `azimuth_deg` in the board plane), rolled
// by `roll_deg` about the viewing axis, with the board centre at `offset` (normalised image
// coordinates x/z, y/z) in the image: the benchmark's and the tests' view generator.
Pose view_pose(double distance, double tilt_deg, double azimuth_deg, double roll_deg, cv::Vec2d offset = {0, 0});

// Rotation error between two poses, degrees; translation error as a fraction of the distance.
double rotation_error_deg(const Pose& estimate, const Pose& truth);
double translation_error_fraction(const Pose& estimate, const Pose& truth);

}  // namespace glint::tracking
