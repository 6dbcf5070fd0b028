// The AR view's camera (appliance/ui/ar_camera.hpp): from a board pose made from a known scene,
// the renderer's eye, view direction, up and field of view come out as the scene says.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtx/quaternion.hpp>

#include "appliance/ui/ar_camera.hpp"

namespace glint::ui {
namespace {

constexpr double kPi = 3.141592653589793;

// world_from_camera (Glint's camera frame) of a camera at `eye` looking at `at`, world +Y up.
glm::dquat look_at(const glm::dvec3& eye, const glm::dvec3& at) {
    const glm::dvec3 back = glm::normalize(eye - at);  // camera +Z
    const glm::dvec3 right = glm::normalize(glm::cross(glm::dvec3(0, 1, 0), back));
    const glm::dvec3 up = glm::cross(back, right);
    return glm::quat_cast(glm::dmat3(right, up, back));
}

struct Scene {
    glm::dquat world_from_board;
    glm::dvec3 board_in_world;
    glm::dvec3 eye_in_world;
    glm::dquat world_from_camera;
    tracking::Pose camera_from_board;  // OpenCV camera frame
};

Scene make_scene(const glm::dvec3& eye, double board_yaw_deg) {
    Scene s;
    // The board flat on the table: its +Z is world +Y, turned about the vertical by board_yaw_deg.
    s.world_from_board = glm::angleAxis(board_yaw_deg * kPi / 180, glm::dvec3(0, 1, 0)) *
                         glm::angleAxis(-kPi / 2, glm::dvec3(1, 0, 0));
    s.board_in_world = glm::dvec3(0.1, 0.7, -0.2);  // a table 0.7 m high, off the origin
    s.eye_in_world = s.board_in_world + eye;
    s.world_from_camera = look_at(s.eye_in_world, s.board_in_world);
    const glm::dquat world_from_cv = s.world_from_camera * kGlFromCv;
    s.camera_from_board.rotation = glm::conjugate(world_from_cv) * s.world_from_board;
    s.camera_from_board.translation = glm::conjugate(world_from_cv) * (s.board_in_world - s.eye_in_world);
    return s;
}

TEST(ArCamera, TheBoardsOrientationInTheWorldIsRecovered) {
    const Scene s = make_scene({0.3, 0.4, 0.5}, 30);
    const glm::dquat wb = world_from_board(s.world_from_camera, s.camera_from_board);
    EXPECT_NEAR(std::abs(glm::dot(wb, s.world_from_board)), 1.0, 1e-12);
    EXPECT_NEAR((wb * glm::dvec3(0, 0, 1)).y, 1.0, 1e-12);  // board +Z is up
}

TEST(ArCamera, EyeTargetUpAndFieldOfViewFollowTheScene) {
    capture::Intrinsics k;
    k.width = 320, k.height = 180, k.fx = k.fy = 150, k.cx = 159.5, k.cy = 89.5;
    ArPlacement p;
    p.object_radius_m = 0.08;
    p.model_bottom = -0.75;  // the object's centre 0.06 m above the board
    for (double yaw : {0.0, 75.0, -140.0}) {
        const Scene s = make_scene({-0.2, 0.45, 0.35}, yaw);
        const render::Camera c = ar_camera(s.world_from_camera, s.camera_from_board, k, p);
        // The render world is the room's axes, origin at the object's centre, unit its radius.
        const glm::dvec3 centre = s.board_in_world + glm::dvec3(0, 0.06, 0);
        const glm::dvec3 expected_eye = (s.eye_in_world - centre) / 0.08;
        EXPECT_NEAR(glm::length(c.eye - expected_eye), 0.0, 1e-9) << "board yaw " << yaw;
        const glm::dvec3 forward = glm::normalize(c.target - c.eye);
        const glm::dvec3 to_board = glm::normalize(s.board_in_world - s.eye_in_world);
        EXPECT_NEAR(glm::dot(forward, to_board), 1.0, 1e-12);
        EXPECT_NEAR(glm::dot(c.up, forward), 0.0, 1e-12);
        EXPECT_GT(c.up.y, 0.0);  // the camera is upright
    }
    const render::Camera c = ar_camera(glm::dquat(1, 0, 0, 0), tracking::Pose{}, k, p);
    EXPECT_NEAR(c.fov_y_deg, 2 * std::atan(90.0 / 150.0) * 180 / kPi, 1e-9);
}

// The object's motion blur from two tracked poses: a board sliding 1 cm to the camera's right at
// 0.5 m, 1/30 s apart, with a 1/60 s exposure, on a view twice the camera's height: the centre
// moves fx x 0.01 / depth camera pixels between the frames, half of that within the exposure,
// times 2 on the view; a move down in the image is a move down (negative y) on the view.
TEST(ArCamera, MotionBlurIsTheCentresImageMotionWithinTheExposure) {
    capture::Intrinsics k;
    k.width = 320, k.height = 180, k.fx = 300, k.fy = 300, k.cx = 160, k.cy = 90;
    const ArPlacement p{0.08, -0.75};  // centre 6 cm above the board
    tracking::Pose a, b;
    a.translation = {0.0, 0.0, 0.5};
    b.translation = {0.01, 0.0, 0.5};
    const glm::dvec2 m = ar_motion_blur_px(a, b, 1.0 / 30, 1.0 / 60, k, 360, p);
    // The board faces the camera (identity rotation): the centre, 6 cm up the board's +Z, is 0.56 m away.
    EXPECT_NEAR(m.x, 300 * 0.01 / 0.56 * 0.5 * 2, 1e-9);
    EXPECT_NEAR(m.y, 0.0, 1e-9);
    b.translation = {0.0, 0.02, 0.5};  // OpenCV's +y is down in the image
    EXPECT_LT(ar_motion_blur_px(a, b, 1.0 / 30, 1.0 / 60, k, 180, p).y, 0.0);
    EXPECT_EQ(ar_motion_blur_px(a, a, 1.0 / 30, 1.0 / 60, k, 180, p), glm::dvec2(0.0));
    EXPECT_EQ(ar_motion_blur_px(a, b, 0.0, 1.0 / 60, k, 180, p), glm::dvec2(0.0));  // no interval
    tracking::Pose behind = b;
    behind.translation.z = -0.5;
    EXPECT_EQ(ar_motion_blur_px(a, behind, 1.0 / 30, 1.0 / 60, k, 180, p), glm::dvec2(0.0));
    b.translation = {0.5, 0.0, 0.5};  // a jump: capped under 256 pixels, direction kept
    const glm::dvec2 capped = ar_motion_blur_px(a, b, 1.0 / 30, 1.0 / 30, k, 180, p);
    EXPECT_LT(glm::length(capped), 256.0);  // what set_camera_match accepts
    EXPECT_GT(glm::length(capped), 255.9);
    EXPECT_GT(capped.x, 0.0);
}

TEST(ArCamera, TheOrbitCirclesTheObjectAtItsDistance) {
    for (double az : {0.0, 90.0, 200.0}) {
        const render::Camera c = orbit_camera(az, 20, 3.5);
        EXPECT_NEAR(glm::length(c.eye), 3.5, 1e-12);
        EXPECT_NEAR(std::asin(c.eye.y / 3.5) * 180 / kPi, 20, 1e-9);
        EXPECT_EQ(c.target, glm::dvec3(0));
    }
    EXPECT_NEAR(orbit_camera(0).eye.z, 3.5 * std::cos(20 * kPi / 180), 1e-12);  // azimuth 0 on +Z
    EXPECT_NEAR(orbit_camera(90).eye.x, 3.5 * std::cos(20 * kPi / 180), 1e-12);
}

}  // namespace
}  // namespace glint::ui
