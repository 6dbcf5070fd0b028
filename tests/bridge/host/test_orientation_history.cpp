#include <gtest/gtest.h>

#include <cmath>

#include "firmware_bridge/host/orientation_history.hpp"

namespace glint::host {
namespace {

constexpr double kPi = 3.14159265358979323846;

Quatd about_y(double angle_rad) { return Quatd::from_axis_angle({0, 1, 0}, angle_rad); }

OrientationSample sample(std::int64_t t_ns, Quatd q) { return {t_ns, q, 0}; }

TEST(OrientationHistory, InterpolatesAtConstantAngularVelocity) {
    OrientationHistory h(16);
    ASSERT_TRUE(h.push(sample(0, about_y(0))));
    ASSERT_TRUE(h.push(sample(10'000'000, about_y(0.2))));
    for (double f : {0.0, 0.25, 0.5, 0.9}) {
        const auto t = static_cast<std::int64_t>(f * 1e7);
        const HistoryAnswer a = h.at(t);
        ASSERT_TRUE(a.q.has_value()) << f;
        EXPECT_NEAR(firmware::angle_between(*a.q, about_y(0.2 * f)), 0.0, 1e-9) << f;
    }
    EXPECT_EQ(h.at(5'000'000).lookup, Lookup::Interpolated);
    EXPECT_EQ(h.at(0).lookup, Lookup::Exact);
    EXPECT_EQ(h.at(10'000'000).lookup, Lookup::Exact);
}

TEST(OrientationHistory, TakesTheShortWayAcrossTheSignFlip) {
    // q and -q are one rotation: a sender that flips the sign between samples must not make the
    // interpolation swing the long way round.
    OrientationHistory h(16);
    const Quatd a = about_y(kPi - 0.05);
    Quatd b = about_y(kPi + 0.05);  // w < 0: normalised to the other sign on push
    ASSERT_TRUE(h.push(sample(0, a)));
    ASSERT_TRUE(h.push(sample(1'000'000, b)));
    const HistoryAnswer mid = h.at(500'000);
    ASSERT_TRUE(mid.q);
    EXPECT_NEAR(firmware::angle_between(*mid.q, about_y(kPi)), 0.0, 1e-9);
}

TEST(OrientationHistory, RefusesOutOfOrderSamplesAndAnswersNothingOutsideItsSpan) {
    OrientationHistory h(16, /*max_gap_ns=*/50'000'000, /*max_hold_ns=*/5'000'000);
    EXPECT_EQ(h.at(0).lookup, Lookup::BeforeFirst);
    ASSERT_TRUE(h.push(sample(100, about_y(0))));
    EXPECT_FALSE(h.push(sample(100, about_y(1))));
    EXPECT_FALSE(h.push(sample(50, about_y(1))));
    EXPECT_EQ(h.size(), 1u);
    EXPECT_FALSE(h.at(99).q);
    EXPECT_EQ(h.at(99).lookup, Lookup::BeforeFirst);
    // Held for max_hold after the newest sample, then no answer.
    EXPECT_TRUE(h.at(100 + 5'000'000).q);
    EXPECT_EQ(h.at(100 + 5'000'000).lookup, Lookup::AfterLast);
    EXPECT_FALSE(h.at(100 + 5'000'001).q);
}

TEST(OrientationHistory, DoesNotInterpolateAcrossALostStretch) {
    OrientationHistory h(16, /*max_gap_ns=*/50'000'000);
    ASSERT_TRUE(h.push(sample(0, about_y(0))));
    ASSERT_TRUE(h.push(sample(50'000'000, about_y(0.1))));
    ASSERT_TRUE(h.push(sample(150'000'000, about_y(1.0))));
    EXPECT_TRUE(h.at(25'000'000).q);
    const HistoryAnswer gap = h.at(100'000'000);
    EXPECT_FALSE(gap.q);
    EXPECT_EQ(gap.lookup, Lookup::Gap);
}

TEST(OrientationHistory, KeepsOnlyTheNewestCapacitySamples) {
    OrientationHistory h(4);
    for (int i = 0; i < 10; ++i) ASSERT_TRUE(h.push(sample(i * 1000, about_y(0.01 * i))));
    EXPECT_EQ(h.size(), 4u);
    EXPECT_EQ(h.oldest()->t_ns, 6000);
    EXPECT_EQ(h.newest()->t_ns, 9000);
    EXPECT_FALSE(h.at(5999).q);
    const HistoryAnswer a = h.at(8500);
    ASSERT_TRUE(a.q);
    EXPECT_NEAR(firmware::angle_between(*a.q, about_y(0.085)), 0.0, 1e-9);
}

TEST(OrientationHistory, NormalisesWhatItStores) {
    OrientationHistory h(4);
    ASSERT_TRUE(h.push(sample(0, Quatd{2, 0, 0, 0})));
    EXPECT_DOUBLE_EQ(h.newest()->q.w, 1.0);
    ASSERT_TRUE(h.push(sample(1, Quatd{0, 0, 0, 0})));  // garbage becomes the identity, not NaN
    EXPECT_TRUE(std::isfinite(h.newest()->q.w));
}

}  // namespace
}  // namespace glint::host
