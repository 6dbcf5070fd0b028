#include <gtest/gtest.h>

#include <cmath>

#include "appliance/core/rotation.hpp"
#include "firmware_bridge/firmware/rotation.hpp"
#include "firmware_bridge/host/orientation_history.hpp"

namespace glint::host {
namespace {

constexpr double kPi = 3.14159265358979323846;

glm::dquat about_y(double angle_rad) { return glm::angleAxis(angle_rad, glm::dvec3(0, 1, 0)); }

OrientationSample sample(std::int64_t t_ns, glm::dquat q) { return {t_ns, q, 0}; }

TEST(OrientationHistory, InterpolatesAtConstantAngularVelocity) {
    OrientationHistory h(16);
    ASSERT_TRUE(h.push(sample(0, about_y(0))));
    ASSERT_TRUE(h.push(sample(10'000'000, about_y(0.2))));
    for (double f : {0.0, 0.25, 0.5, 0.9}) {
        const auto t = static_cast<std::int64_t>(f * 1e7);
        const HistoryAnswer a = h.at(t);
        ASSERT_TRUE(a.world_from_sensor.has_value()) << f;
        EXPECT_NEAR(angle_between(*a.world_from_sensor, about_y(0.2 * f)), 0.0, 1e-9) << f;
    }
    EXPECT_EQ(h.at(5'000'000).lookup, Lookup::Interpolated);
    EXPECT_EQ(h.at(0).lookup, Lookup::Exact);
    EXPECT_EQ(h.at(10'000'000).lookup, Lookup::Exact);
}

TEST(OrientationHistory, TakesTheShortWayAcrossTheSignFlip) {
    // q and -q are one rotation: a sender that flips the sign between samples must not make the
    // interpolation swing the long way round.
    OrientationHistory h(16);
    const glm::dquat a = about_y(kPi - 0.05);
    const glm::dquat b = about_y(kPi + 0.05);  // w < 0
    ASSERT_TRUE(h.push(sample(0, a)));
    ASSERT_TRUE(h.push(sample(1'000'000, b)));
    const HistoryAnswer mid = h.at(500'000);
    ASSERT_TRUE(mid.world_from_sensor);
    EXPECT_NEAR(angle_between(*mid.world_from_sensor, about_y(kPi)), 0.0, 1e-9);
}

TEST(OrientationHistory, RefusesOutOfOrderSamplesAndAnswersNothingOutsideItsSpan) {
    OrientationHistory h(16, /*max_gap_ns=*/50'000'000, /*max_hold_ns=*/5'000'000);
    EXPECT_EQ(h.at(0).lookup, Lookup::BeforeFirst);
    ASSERT_TRUE(h.push(sample(100, about_y(0))));
    EXPECT_FALSE(h.push(sample(100, about_y(1))));
    EXPECT_FALSE(h.push(sample(50, about_y(1))));
    EXPECT_EQ(h.size(), 1u);
    EXPECT_FALSE(h.at(99).world_from_sensor);
    EXPECT_EQ(h.at(99).lookup, Lookup::BeforeFirst);
    // Held for max_hold after the newest sample, then no answer.
    EXPECT_TRUE(h.at(100 + 5'000'000).world_from_sensor);
    EXPECT_EQ(h.at(100 + 5'000'000).lookup, Lookup::AfterLast);
    EXPECT_FALSE(h.at(100 + 5'000'001).world_from_sensor);
}

TEST(OrientationHistory, DoesNotInterpolateAcrossALostStretch) {
    OrientationHistory h(16, /*max_gap_ns=*/50'000'000);
    ASSERT_TRUE(h.push(sample(0, about_y(0))));
    ASSERT_TRUE(h.push(sample(50'000'000, about_y(0.1))));
    ASSERT_TRUE(h.push(sample(150'000'000, about_y(1.0))));
    EXPECT_TRUE(h.at(25'000'000).world_from_sensor);
    const HistoryAnswer gap = h.at(100'000'000);
    EXPECT_FALSE(gap.world_from_sensor);
    EXPECT_EQ(gap.lookup, Lookup::Gap);
}

TEST(OrientationHistory, KeepsOnlyTheNewestCapacitySamples) {
    OrientationHistory h(4);
    for (int i = 0; i < 10; ++i) ASSERT_TRUE(h.push(sample(i * 1000, about_y(0.01 * i))));
    EXPECT_EQ(h.size(), 4u);
    EXPECT_EQ(h.oldest()->t_ns, 6000);
    EXPECT_EQ(h.newest()->t_ns, 9000);
    EXPECT_FALSE(h.at(5999).world_from_sensor);
    const HistoryAnswer a = h.at(8500);
    ASSERT_TRUE(a.world_from_sensor);
    EXPECT_NEAR(angle_between(*a.world_from_sensor, about_y(0.085)), 0.0, 1e-9);
}

TEST(OrientationHistory, ToGlmGivesUnitQuaternionsWithWNotNegative) {
    EXPECT_DOUBLE_EQ(to_glm(firmware::Quatd{2, 0, 0, 0}).w, 1.0);
    const glm::dquat flipped = to_glm(firmware::Quatd{-0.6, 0, 0.8, 0});
    EXPECT_DOUBLE_EQ(flipped.w, 0.6);
    EXPECT_DOUBLE_EQ(flipped.y, -0.8);
    // Garbage becomes the identity, not NaN.
    EXPECT_EQ(to_glm(firmware::Quatd{0, 0, 0, 0}), glm::dquat(1, 0, 0, 0));
    EXPECT_EQ(to_glm(firmware::Quatd{NAN, 0, 0, 0}), glm::dquat(1, 0, 0, 0));
}

}  // namespace
}  // namespace glint::host
