#include "appliance/ui/ar_camera.hpp"

#include <cmath>

namespace glint::ui {

tracking::Camera tracking_camera(const capture::Intrinsics& k) {
    return {k.width, k.height, k.fx, k.fy, k.cx, k.cy, k.k1, k.k2, k.p1, k.p2, k.k3};
}

glm::dquat world_from_board(const glm::dquat& world_from_camera, const tracking::Pose& camera_from_board) {
    return glm::normalize(world_from_camera * kGlFromCv * camera_from_board.rotation);
}

render::Camera ar_camera(const glm::dquat& world_from_camera, const tracking::Pose& camera_from_board,
                         const capture::Intrinsics& k, const ArPlacement& p) {
    const glm::dquat wb = world_from_board(world_from_camera, camera_from_board);
    const glm::dvec3 camera_in_board = camera_from_board.inverse().translation;  // metres
    const glm::dvec3 centre_in_board(0.0, 0.0, -p.model_bottom * p.object_radius_m);
    render::Camera c;
    c.eye = wb * (camera_in_board - centre_in_board) / p.object_radius_m;
    c.target = c.eye + world_from_camera * glm::dvec3(0, 0, -1);
    c.up = world_from_camera * glm::dvec3(0, 1, 0);
    c.fov_y_deg = 2.0 * std::atan(0.5 * double(k.height) / k.fy) * 180.0 / 3.141592653589793;
    // 5 mm for an 8 cm object: close enough for a visitor's hand, far enough for depth precision.
    c.near = 0.06;
    c.far = 200.0;
    return c;
}

glm::dvec2 ar_motion_blur_px(const tracking::Pose& previous, const tracking::Pose& current, double dt_s, double exposure_s,
                             const capture::Intrinsics& k, int view_height, const ArPlacement& p) {
    if (!(dt_s > 0) || !(exposure_s > 0) || k.height <= 0 || view_height <= 0) return {0.0, 0.0};
    const glm::dvec3 centre_in_board(0.0, 0.0, -p.model_bottom * p.object_radius_m);
    const glm::dvec3 a = previous.apply(centre_in_board), b = current.apply(centre_in_board);  // OpenCV camera frame
    if (!(a.z > 0) || !(b.z > 0)) return {0.0, 0.0};
    const double scale = double(view_height) / double(k.height);  // camera pixels -> view pixels
    // The view's y grows upwards, OpenCV's downwards.
    glm::dvec2 motion(scale * k.fx * (b.x / b.z - a.x / a.z), -scale * k.fy * (b.y / b.z - a.y / a.z));
    motion *= exposure_s / dt_s;
    const double length = glm::length(motion);
    if (!std::isfinite(length)) return {0.0, 0.0};
    // Scaled to a little under the limit: the rounded product may come out above 256 itself.
    return length > 255.99 ? motion * (255.99 / length) : motion;
}

render::Camera orbit_camera(double azimuth_deg, double elevation_deg, double distance, double fov_y_deg) {
    const double a = azimuth_deg * 3.141592653589793 / 180.0, e = elevation_deg * 3.141592653589793 / 180.0;
    render::Camera c;
    c.eye = distance * glm::dvec3(std::sin(a) * std::cos(e), std::sin(e), std::cos(a) * std::cos(e));
    c.target = glm::dvec3(0);
    c.fov_y_deg = fov_y_deg;
    return c;
}

}  // namespace glint::ui
