// The One Euro pose filter (jitter and lag) and the dropout bridge (sensor rotation, fade-out).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "appliance/tracking/board_view.hpp"
#include "appliance/tracking/dropout_bridge.hpp"
#include "appliance/tracking/pose_filter.hpp"
#include "appliance/tracking/tracker.hpp"

namespace glint::tracking {
namespace {

constexpr double kDeg = std::numbers::pi / 180;

Pose noisy(const Pose& p, double sigma_deg, double sigma_m, std::mt19937& rng) {
    std::normal_distribution<double> n(0, 1);
    const glm::dvec3 r(n(rng), n(rng), n(rng));
    return {unit_rotation(rotation_from_vector(r * (sigma_deg * kDeg)) * p.rotation),
            p.translation + glm::dvec3(n(rng), n(rng), n(rng)) * sigma_m};
}

TEST(TrackingFilter, StillPoseJitterIsReduced) {
    std::mt19937 rng(3);
    const Pose truth = view_pose(1.0, 30, 10, 5);
    PoseFilter filter;
    double raw = 0, filtered = 0;
    int n = 0;
    for (int i = 0; i < 300; ++i) {
        const Pose m = noisy(truth, 0.02, 0.0002, rng);
        const Pose f = filter.update(i / 30.0, m);
        if (i < 60) continue;  // settled
        raw += std::pow(rotation_error_deg(m, truth), 2);
        filtered += std::pow(rotation_error_deg(f, truth), 2);
        ++n;
    }
    EXPECT_LT(std::sqrt(filtered / n), 0.3 * std::sqrt(raw / n));
}

TEST(TrackingFilter, FollowsARampWithinAFrame) {
    PoseFilter filter;
    const Pose start = view_pose(1.0, 0, 0, 0);
    const double speed = 30 * kDeg;  // rad/s about the camera's y axis
    double lag_s = 0;
    for (int i = 0; i <= 90; ++i) {
        const double t = i / 30.0;
        const Pose m{unit_rotation(glm::angleAxis(speed * t, glm::dvec3(0, 1, 0)) * start.rotation), start.translation};
        const Pose f = filter.update(t, m);
        lag_s = rotation_error_deg(f, m) * kDeg / speed;
    }
    EXPECT_LT(lag_s, 1 / 30.0);
    EXPECT_GT(lag_s, 0.0);  // a low-pass must lag somewhat: the test would notice a pass-through
}

TEST(TrackingBridge, SensorCarriesTheRotationThenFades) {
    // The mounting: sensor axes differ from the camera's by a known rotation.
    const glm::dquat sensor_from_camera = glm::angleAxis(0.3, glm::normalize(glm::dvec3(1, 2, 3)));
    DropoutBridge bridge(sensor_from_camera);
    const Pose board_at_0 = view_pose(0.8, 25, 30, 10);
    // The camera turns at 20 deg/s about its own y axis; the board is still in the world.
    const auto camera_turn = [](double t) { return glm::angleAxis(20 * kDeg * t, glm::dvec3(0, 1, 0)); };
    const glm::dquat world_from_camera0 = glm::angleAxis(0.7, glm::dvec3(0, 0, 1));
    for (int i = 0; i <= 100; ++i) {
        const double t = i * 0.01;
        const glm::dquat world_from_camera = world_from_camera0 * camera_turn(t);
        bridge.add_orientation({t, world_from_camera * glm::conjugate(sensor_from_camera)});
    }
    EXPECT_FALSE(bridge.bridge(0.1).has_value());  // nothing seen yet
    bridge.on_detection(0.0, board_at_0);
    const auto truth_at = [&](double t) {
        return Pose{unit_rotation(glm::conjugate(camera_turn(t))), glm::dvec3(0)} * board_at_0;
    };
    const auto at_04 = bridge.bridge(0.4);
    ASSERT_TRUE(at_04.has_value());
    EXPECT_TRUE(at_04->from_sensor);
    EXPECT_DOUBLE_EQ(at_04->visibility, 1.0);
    EXPECT_LT(rotation_error_deg(at_04->pose, truth_at(0.4)), 1e-6);
    EXPECT_GT(rotation_error_deg(board_at_0, truth_at(0.4)), 7.9);  // holding would be 8 degrees off
    const auto at_06 = bridge.bridge(0.6);
    ASSERT_TRUE(at_06.has_value());
    EXPECT_NEAR(at_06->visibility, 0.6, 1e-9);
    EXPECT_FALSE(bridge.bridge(0.76).has_value());
    // Without orientation samples the pose is held.
    DropoutBridge blind(sensor_from_camera);
    blind.on_detection(0.0, board_at_0);
    const auto held = blind.bridge(0.3);
    ASSERT_TRUE(held.has_value());
    EXPECT_FALSE(held->from_sensor);
    EXPECT_LT(rotation_error_deg(held->pose, board_at_0), 1e-5);
}

TEST(TrackingTracker, DetectsFiltersAndBridgesABlankFrame) {
    const Board board;
    const Camera cam = Camera::from_fov(1280, 720, 70);
    const BoardRenderer renderer(board, cam);
    Tracker tracker(board, cam, glm::dquat(1, 0, 0, 0));
    const Pose truth = view_pose(0.9, 30, 80, 20);
    for (int i = 0; i <= 30; ++i) tracker.add_orientation({i * 0.01, glm::dquat(1, 0, 0, 0)});
    const cv::Mat frame = renderer.render(truth, {}, 5);
    for (int i = 0; i < 3; ++i) {
        const TrackResult r = tracker.track(i / 30.0, frame);
        ASSERT_TRUE(r.detected) << r.detection.rejection;
        EXPECT_LT(rotation_error_deg(r.pose, truth), 0.1);
    }
    const TrackResult blank = tracker.track(0.2, cv::Mat(720, 1280, CV_8UC1, cv::Scalar(100)));
    EXPECT_FALSE(blank.detected);
    EXPECT_TRUE(blank.has_pose);
    EXPECT_TRUE(blank.from_sensor);
    EXPECT_LT(rotation_error_deg(blank.pose, truth), 0.1);
    const TrackResult gone = tracker.track(1.0, cv::Mat(720, 1280, CV_8UC1, cv::Scalar(100)));
    EXPECT_FALSE(gone.has_pose);
}

}  // namespace
}  // namespace glint::tracking
