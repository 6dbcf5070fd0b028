#include <gtest/gtest.h>

#include <cmath>

#include "appliance/capture/guided_capture.hpp"
#include "appliance/sim/session_simulator.hpp"

namespace glint::capture {
namespace {

using sim::camera_look;

constexpr int kW = 64, kH = 32;

CameraFrame grey_frame(std::int64_t t_ns, double exposure_s, std::uint8_t code = 120) {
    CameraFrame f;
    f.rgb = cv::Mat(36, 64, CV_8UC3, cv::Scalar(code, code, code));
    f.t_ns = t_ns;
    f.exposure_s = exposure_s;
    return f;
}

std::vector<std::uint32_t> all_covered() { return std::vector<std::uint32_t>(std::size_t(kW * kH), 1); }

Intrinsics camera() { return Intrinsics::from_fov(640, 360, 60 * kPi / 180); }  // fx = 554 px

TEST(GuidedCapture, WarnsWhenTheTurnWouldBlurAFrame) {
    GuidedCapture g({}, camera());
    g.update(grey_frame(0, 0.01), camera_look(0, 0), all_covered(), kW, kH);
    // 10 deg in 0.1 s = 100 deg/s; 10 ms exposure: 1.745 rad/s x 0.01 s x 554 px = 9.7 px.
    GuidedStep s = g.update(grey_frame(100'000'000, 0.01), camera_look(10, 0), all_covered(), kW, kH);
    EXPECT_NEAR(s.angular_speed_deg_s, 100.0, 0.5);
    EXPECT_NEAR(s.blur_px, 9.67, 0.1);
    EXPECT_TRUE(s.too_fast);
    // 1 deg in 0.1 s: 0.97 px.
    s = g.update(grey_frame(200'000'000, 0.01), camera_look(11, 0), all_covered(), kW, kH);
    EXPECT_FALSE(s.too_fast);
    EXPECT_LT(s.blur_px, 1.0);
}

TEST(GuidedCapture, JudgesTheExposureFromTheCodes) {
    GuidedCapture g({}, camera());
    EXPECT_EQ(g.update(grey_frame(0, 0.01, 120), camera_look(0, 0), all_covered(), kW, kH).exposure, ExposureStatus::Ok);
    EXPECT_EQ(g.update(grey_frame(1, 0.01, 255), camera_look(0, 0), all_covered(), kW, kH).exposure,
              ExposureStatus::TooBright);
    EXPECT_EQ(g.update(grey_frame(2, 0.01, 8), camera_look(0, 0), all_covered(), kW, kH).exposure,
              ExposureStatus::TooDark);
    // A small clipped lamp (1 % of the frame) is fine.
    CameraFrame f = grey_frame(3, 0.01);
    f.rgb(cv::Rect(0, 0, 6, 4)) = cv::Scalar(255, 255, 255);
    EXPECT_EQ(g.update(f, camera_look(0, 0), all_covered(), kW, kH).exposure, ExposureStatus::Ok);
}

TEST(GuidedCapture, PointsAtTheLargestUnseenPatchButNotAtTheFloor) {
    // Everything seen except a patch around azimuth 90 (east, +X) and elevation 20, and the floor.
    std::vector<std::uint32_t> s = all_covered();
    const glm::dvec3 patch = direction_from_angles(70 * kPi / 180, kPi / 2);
    for (int j = 0; j < kH; ++j)
        for (int i = 0; i < kW; ++i) {
            const glm::dvec3 d = texel_direction(i, j, kW, kH);
            if (glm::dot(d, patch) > std::cos(0.5) || row_theta(j, kH) > (90 + 80) * kPi / 180)
                s[std::size_t(j * kW + i)] = 0;
        }
    GuidedCapture g({}, camera());
    const GuidedStep step = g.update(grey_frame(0, 0.01), camera_look(0, 0), s, kW, kH);
    EXPECT_GT(glm::dot(step.next_target, patch), std::cos(15 * kPi / 180));  // the patch, not the floor
    EXPECT_NEAR(step.turn_to_target_deg, std::acos(glm::dot(patch, glm::dvec3(0, 0, -1))) * 180 / kPi, 15.0);
    EXPECT_EQ(step.state, GuidedState::Scanning);
    EXPECT_LT(step.progress, 1.0);
    EXPECT_GT(step.progress, 0.9);
}

TEST(GuidedCapture, CompletesOnCoverageOrTimesOut) {
    GuidedSettings settings;
    settings.time_limit_s = 10;
    GuidedCapture done(settings, camera());
    EXPECT_EQ(done.update(grey_frame(0, 0.01), camera_look(0, 0), all_covered(), kW, kH).state, GuidedState::Complete);
    EXPECT_DOUBLE_EQ(done.last().progress, 1.0);

    std::vector<std::uint32_t> half(std::size_t(kW * kH), 0);
    for (int j = 0; j < kH / 2; ++j)
        for (int i = 0; i < kW; ++i) half[std::size_t(j * kW + i)] = 1;
    GuidedCapture slow(settings, camera());
    // A frame a second (a gap over GuidedSettings::pause_after_gap_s would be a pause).
    for (std::int64_t t = 0; t <= 9'000'000'000; t += 1'000'000'000)
        EXPECT_EQ(slow.update(grey_frame(t, 0.01), camera_look(0, 0), half, kW, kH).state, GuidedState::Scanning);
    EXPECT_EQ(slow.update(grey_frame(10'000'000'000, 0.01), camera_look(0, 0), half, kW, kH).state, GuidedState::TimedOut);
}

TEST(GuidedCapture, ASensorLossPausesTheTimeLimit) {
    GuidedSettings settings;
    settings.time_limit_s = 10;
    std::vector<std::uint32_t> half(std::size_t(kW * kH), 0);
    for (int j = 0; j < kH / 2; ++j)
        for (int i = 0; i < kW; ++i) half[std::size_t(j * kW + i)] = 1;
    GuidedCapture g(settings, camera());
    for (std::int64_t t = 0; t <= 4'000'000'000; t += 1'000'000'000)
        EXPECT_EQ(g.update(grey_frame(t, 0.01), camera_look(0, 0), half, kW, kH).state, GuidedState::Scanning);
    // No orientation from 4.1 s to 9 s (the sensor unplugged and replugged): 4.9 s paused.
    for (std::int64_t t = 4'100'000'000; t < 9'000'000'000; t += 100'000'000) g.frame_unplaced(t);
    // Back at 9 s having turned 90 degrees while waiting: that is no speed.
    GuidedStep s = g.update(grey_frame(9'000'000'000, 0.01), camera_look(90, 0), half, kW, kH);
    EXPECT_NEAR(s.elapsed_s, 4.1, 1e-9);
    EXPECT_NEAR(g.paused_s(), 4.9, 1e-9);
    EXPECT_FALSE(s.too_fast);
    // Without the pause 14 s would be past the limit; with it, 9.1 s of scanning is not.
    for (std::int64_t t = 10'000'000'000; t <= 14'000'000'000; t += 1'000'000'000)
        EXPECT_EQ(g.update(grey_frame(t, 0.01), camera_look(90, 0), half, kW, kH).state, GuidedState::Scanning);
    EXPECT_EQ(g.update(grey_frame(15'000'000'000, 0.01), camera_look(90, 0), half, kW, kH).state, GuidedState::TimedOut);
    // Frames not fed at all for 5 s (the kiosk holds them back while a device is lost): paused too.
    GuidedCapture fed(settings, camera());
    fed.update(grey_frame(0, 0.01), camera_look(0, 0), half, kW, kH);
    fed.update(grey_frame(1'000'000'000, 0.01), camera_look(0, 0), half, kW, kH);
    s = fed.update(grey_frame(6'000'000'000, 0.01), camera_look(0, 0), half, kW, kH);
    EXPECT_NEAR(s.elapsed_s, 1.0, 1e-9);
    EXPECT_NEAR(fed.paused_s(), 5.0, 1e-9);
    // An unplaced frame before the scan's first placed one is no pause.
    GuidedCapture early(settings, camera());
    early.frame_unplaced(0);
    early.update(grey_frame(2'000'000'000, 0.01), camera_look(0, 0), half, kW, kH);
    EXPECT_EQ(early.paused_s(), 0.0);
}

}  // namespace
}  // namespace glint::capture
