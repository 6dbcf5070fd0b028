// CapMax: a query bounds every texel of its cap (the cone's widening relies on it).
#include <gtest/gtest.h>

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

}  // namespace
}  // namespace glint::convolution
