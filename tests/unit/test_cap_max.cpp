// CapMax: a query bounds every texel of its cap (the cone's widening relies on it).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

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

}  // namespace
}  // namespace glint::convolution
