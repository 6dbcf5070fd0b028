// CapMax: a query bounds every texel of its cap (the cone's widening relies on it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "appliance/convolution/lobe_sum.hpp"
#include "appliance/core/equirect.hpp"

namespace glint::convolution {
namespace {

HdrImage random_map(int w, int h, unsigned seed) {
    std::mt19937 rng(seed);
    std::lognormal_distribution<float> radiance(0.0f, 2.0f);
    HdrImage img(w, h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) img.set(i, j, {radiance(rng), radiance(rng), radiance(rng)});
    return img;
}

TEST(CapMax, QueryBoundsEveryTexelOfItsCap) {
    const HdrImage img = random_map(64, 32, 5);
    const PreparedLevel level(img);
    const double radius = 0.3;
    const CapMax cap(level, radius);
    for (int row = 0; row < 16; ++row)
        for (int col = 0; col < 32; ++col) {
            const double theta = row_theta(row, 16), phi = column_phi(col, 32);
            const glm::dvec3 centre = direction_from_angles(theta, phi);
            const double bound = cap.query(theta, phi);
            for (int j = 0; j < 32; ++j)
                for (int i = 0; i < 64; ++i) {
                    const glm::dvec3 d = direction_from_angles(row_theta(j, 32), column_phi(i, 64));
                    if (centre.x * d.x + centre.y * d.y + centre.z * d.z < std::cos(radius)) continue;
                    const Rgb l = img.at(i, j);
                    ASSERT_LE(std::max({l.r, l.g, l.b}), bound) << row << "," << col << " texel " << i << "," << j;
                }
        }
}

// The other side: a bound that is always the map's maximum would pass the test above and make
// the cone widen every texel. Each answer must be the value of a texel near the cap. The cap's
// rows are grouped in blocks of about the radius (lobe_sum.hpp), so the texel's polar angle is
// within 2 r + one row of the centre's; a cap that holds no pole also narrows the columns to
// its azimuth range plus one column, so there the texel is within 2 r + one texel of the centre
// (measured: 0.64 rad for r = 0.3, bound 0.70). A cap holding a pole counts whole rows, so only the polar
// angle is bounded there. Most answers are far below the map's maximum.
TEST(CapMax, QueryIsTheValueOfATexelNearTheCap) {
    const HdrImage img = random_map(64, 32, 5);
    const PreparedLevel level(img);
    const double radius = 0.3;
    const CapMax cap(level, radius);
    const double pi = 3.14159265358979323846;
    const double texel = 2.0 * pi / 64;  // one column at the equator (and one row), rad
    double farthest = 0;
    int below_global = 0, pole_caps = 0;
    for (int row = 0; row < 16; ++row)
        for (int col = 0; col < 32; ++col) {
            const double theta = row_theta(row, 16), phi = column_phi(col, 32);
            const bool holds_pole = theta - radius <= 0 || theta + radius >= pi;
            pole_caps += holds_pole ? 1 : 0;
            const glm::dvec3 centre = direction_from_angles(theta, phi);
            const double bound = cap.query(theta, phi);
            bool found = false;
            double nearest = 10;  // angle to the nearest such texel (caps without a pole)
            for (int j = 0; j < 32; ++j) {
                if (std::abs(row_theta(j, 32) - theta) > 2 * radius + texel) continue;
                for (int i = 0; i < 64; ++i) {
                    const Rgb l = img.at(i, j);
                    if (double(std::max({l.r, l.g, l.b})) != bound) continue;
                    found = true;
                    const glm::dvec3 d = direction_from_angles(row_theta(j, 32), column_phi(i, 64));
                    const double dot = centre.x * d.x + centre.y * d.y + centre.z * d.z;
                    nearest = std::min(nearest, std::acos(std::clamp(dot, -1.0, 1.0)));
                }
            }
            EXPECT_TRUE(found) << "query at " << row << "," << col << " = " << bound
                               << " is no texel within 2 r + one row in polar angle";
            if (!holds_pole) {
                farthest = std::max(farthest, nearest);
                EXPECT_LE(nearest, 2 * radius + texel) << "query at " << row << "," << col << " = " << bound;
            }
            below_global += bound < level.max_value() ? 1 : 0;
        }
    std::printf("[  report  ] cap max: caps without a pole answered by a texel within %.3f rad (radius %.2f); "
                "%d of 512 answers below the map's maximum\n",
                farthest, radius, below_global);
    EXPECT_GE(pole_caps, 64);  // both kinds of cap are exercised
    EXPECT_GE(below_global, 400);
}

// max_channel_row_sum reads eight texels at a time in shuffled vectors: each texel's largest
// channel counts once, whichever channel it is, at every width (the last texels one by one).
TEST(LevelSums, MaxChannelRowSumCountsEachTexelsLargestChannel) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> value(0.0f, 1.0f);
    for (int width = 1; width <= 41; ++width) {
        std::vector<float> rgb(3 * std::size_t(width));
        double expected = 0;
        for (int i = 0; i < width; ++i) {
            // The largest channel placed in turn: red, green, blue.
            const int top = (i * 7 + width) % 3;
            for (int c = 0; c < 3; ++c) rgb[3 * std::size_t(i) + std::size_t(c)] = value(rng);
            rgb[3 * std::size_t(i) + std::size_t(top)] = 2.0f + float(i);
            expected += 2.0 + i;
        }
        EXPECT_NEAR(max_channel_row_sum(rgb.data(), width), expected, 1e-12 * expected) << "width " << width;
    }
}

// The merge factors' smoothness test, read a block of groups at a time, decides as the rule
// group by group does (written out here) on rough and smooth rows and at every limit.
TEST(LevelSums, PolarMergeFactorsFollowTheGroupRule) {
    const auto rule = [](const PreparedLevel& level, int out_width, double max_arc, double limit) {
        const int w = level.width(), h = level.height();
        const double mean = level.power() / (4.0 * kPi);
        std::vector<int> factor(std::size_t(h), 1);
        for (int j = 0; j < h; ++j) {
            const double edge = std::clamp(kPi / 2, j * kPi / h, (j + 1) * kPi / h);
            const double arc = std::sin(edge) * kTwoPi / w;
            const int most = polar_merge_factor(j, w, h, out_width, max_arc);
            for (int m = 2; m <= most; m *= 2) {
                bool smooth = true;
                for (int c = 0; c < 3 && smooth; ++c)
                    for (int g = 0; g < w && smooth; g += m) {
                        double sum = 0, spread = 0;
                        for (int k = g; k < g + m; ++k) sum += level.plane(j, c)[k];
                        for (int k = g; k < g + m; ++k) spread += std::abs(level.plane(j, c)[k] - sum / m);
                        const double base = sum + m * mean;
                        if (base > 0 && m * arc * (spread / base) > limit) smooth = false;
                    }
                if (!smooth) break;
                factor[std::size_t(j)] = m;
            }
        }
        return factor;
    };
    // Rough rows: lognormal noise; smooth ones: a gentle gradient with a few rough texels and
    // negative zeros. Widths and output widths that reach every group size (M up to 64 at
    // 512 / 1) and a width that leaves groups after the last block of eight (96 / 3: M = 8,
    // one block and four groups); a level holding a NaN decides as the rule does too.
    const auto smooth_map = [](int w, int h) {
        HdrImage img(w, h);
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) {
                const float v = 1.0f + 0.001f * float(i % 64) + ((i * 31 + j * 17) % 97 == 0 ? 0.5f : 0.0f);
                img.set(i, j, {v, v * 0.9f, (i + j) % 13 == 0 ? -0.0f : v * 1.1f});
            }
        return img;
    };
    struct Case {
        int w, h, out_width;
    };
    int merged = 0, limits = 0;
    for (const Case c : {Case{256, 128, 64}, Case{512, 256, 1}, Case{96, 48, 3}}) {
        const HdrImage smooth = smooth_map(c.w, c.h);
        HdrImage with_nan = smooth_map(c.w, c.h);
        with_nan.set(c.w / 2, 1, {std::nanf(""), 1.0f, 1.0f});
        const HdrImage noise = random_map(c.w, c.h, 9);
        const PreparedLevel levels[3] = {PreparedLevel(smooth, 1), PreparedLevel(noise, 1), PreparedLevel(with_nan, 1)};
        for (double limit : {0.0, 1e-6, 1e-4, 1e-3, 1e-2, 0.1, 1.0}) {
            for (const PreparedLevel& l : levels) {
                const std::vector<int> got = polar_merge_factors(l, c.out_width, 0.2, limit);
                EXPECT_EQ(got, rule(l, c.out_width, 0.2, limit)) << c.w << "x" << c.h << " to " << c.out_width
                                                                 << " columns, limit " << limit;
                for (int f : got) merged += f > 1;
            }
            ++limits;
        }
    }
    std::printf("[  report  ] merge factors: %d merged rows over %d limits and three grids\n", merged, limits);
    EXPECT_GT(merged, 20);  // the rule merges somewhere, so that its decisions are compared
}

}  // namespace
}  // namespace glint::convolution
