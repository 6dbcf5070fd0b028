#include <gtest/gtest.h>

#include <cmath>

#include "appliance/capture/coverage.hpp"
#include "appliance/core/errors.hpp"

namespace glint::capture {
namespace {

TEST(Coverage, FullAndEmptySpheres) {
    const int w = 64, h = 32;
    std::vector<std::uint32_t> all(std::size_t(w * h), 3), none(std::size_t(w * h), 0);
    EXPECT_NEAR(measure_coverage(all, w, h, 1).covered_fraction, 1.0, 1e-12);
    EXPECT_NEAR(measure_coverage(all, w, h, 4).covered_fraction, 0.0, 1e-12);  // below min_samples
    EXPECT_NEAR(measure_coverage(none, w, h, 1).covered_fraction, 0.0, 1e-12);
    EXPECT_EQ(measure_coverage(all, w, h, 1).largest_gap_sr, 0.0);
}

TEST(Coverage, CountsSolidAngleNotTexelsAndFindsTheFloor) {
    // Everything below 60 degrees under the horizon is unseen (the stand): a cap of
    // 2 pi (1 - cos 30 deg) steradians around -Y.
    const int w = 128, h = 64;
    std::vector<std::uint32_t> s(std::size_t(w * h), 1);
    for (int j = 0; j < h; ++j)
        if (row_theta(j, h) > (90.0 + 60.0) * kPi / 180.0)
            for (int i = 0; i < w; ++i) s[std::size_t(j * w + i)] = 0;
    const CoverageReport r = measure_coverage(s, w, h, 1);
    const double hole = 2 * kPi * (1 - std::cos(30.0 * kPi / 180.0));
    EXPECT_NEAR(r.covered_fraction, 1 - hole / (4 * kPi), 0.01);
    EXPECT_LT(r.largest_gap.y, -0.95);  // straight down
    EXPECT_NEAR(r.largest_gap_sr, hole, 0.1 * hole);
}

TEST(Coverage, FillInterpolatesInsideAColumnAndUsesTheNearestRingBelow) {
    const int w = 8, h = 8;
    HdrImage img(w, h);
    std::vector<std::uint32_t> s(std::size_t(w * h), 1);
    for (int i = 0; i < w; ++i)
        for (int j = 0; j < h; ++j) img.set(i, j, {float(j), float(2 * j), float(i)});
    // A hole in column 2, rows 2..4, between covered rows 1 and 5; the floor rows 6, 7 unseen.
    for (int j = 2; j <= 4; ++j) s[std::size_t(j * w + 2)] = 0;
    for (int i = 0; i < w; ++i) s[std::size_t(6 * w + i)] = s[std::size_t(7 * w + i)] = 0;
    for (int j = 2; j <= 4; ++j) img.set(2, j, {-1, -1, -1});
    for (int i = 0; i < w; ++i) img.set(i, 7, {-5, -5, -5});
    const long long filled = fill_uncovered(img, s, 1);
    EXPECT_EQ(filled, 3 + 2 * w);
    for (int j = 2; j <= 4; ++j) {
        EXPECT_FLOAT_EQ(img.at(2, j).r, float(j));  // linear between rows 1 and 5
        EXPECT_FLOAT_EQ(img.at(2, j).g, float(2 * j));
    }
    // The floor takes the mean of every column's last covered texel (row 5).
    for (int i = 0; i < w; ++i)
        for (int j = 6; j < 8; ++j) {
            EXPECT_FLOAT_EQ(img.at(i, j).r, 5.0f);
            EXPECT_FLOAT_EQ(img.at(i, j).b, 3.5f);  // mean of column indices 0..7
        }
}

TEST(Coverage, NothingCoveredLeavesTheMapAlone) {
    HdrImage img(4, 2);
    img.set(1, 1, {7, 7, 7});
    std::vector<std::uint32_t> s(8, 0);
    EXPECT_EQ(fill_uncovered(img, s, 1), 0);
    EXPECT_EQ(img.at(1, 1).r, 7.0f);
}

TEST(Coverage, ImageChannelsAreSamplesWeightAndCovered) {
    std::vector<std::uint32_t> s{0, 1, 2, 5};
    std::vector<float> w{0.0f, 0.5f, 1.5f, 4.0f};
    const HdrImage img = coverage_image(s, w, 2, 2, 2);
    EXPECT_EQ(img.at(1, 0).r, 1.0f);
    EXPECT_EQ(img.at(1, 0).b, 0.0f);
    EXPECT_EQ(img.at(0, 1).g, 1.5f);
    EXPECT_EQ(img.at(0, 1).b, 1.0f);
}

TEST(Coverage, WeakSamplesThatSumToAUsableWeightCountAsSampled) {
    // Texel 0: one good sample; 1: weak samples summing over the threshold; 2: weak samples
    // under it; 3: never seen. Only 2 and 3 stay unsampled (the fill replaces them).
    const std::vector<std::uint32_t> got =
        samples_with_summed_weight({3, 0, 0, 0}, {0.9f, 0.05f, 0.01f, 0.0f}, 0.02);
    EXPECT_EQ(got, (std::vector<std::uint32_t>{3, 1, 0, 0}));
    EXPECT_THROW(samples_with_summed_weight({1, 2}, {0.5f}, 0.02), RuntimeError);
}

}  // namespace
}  // namespace glint::capture
