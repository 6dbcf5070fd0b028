// Tests of the equirectangular conventions (docs/conventions.md) as implemented in core/equirect.
#include <gtest/gtest.h>

#include <cmath>
#include <utility>
#include <vector>

#include "appliance/core/equirect.hpp"

namespace glint {
namespace {

const std::vector<std::pair<int, int>> kSizes = {{8, 4}, {300, 200}, {64, 32}, {7, 3}, {1, 1},
                                                 {512, 256}};

TEST(Equirect, DirectionTexelRoundTripAtEveryTexelCentre) {
    for (const auto& [w, h] : kSizes) {
        for (int j = 0; j < h; ++j) {
            for (int i = 0; i < w; ++i) {
                const glm::dvec3 d = texel_direction(i, j, w, h);
                ASSERT_NEAR(glm::dot(d, d), 1.0, 1e-12);
                const TexelCoord t = direction_to_texel(d, w, h);
                ASSERT_NEAR(t.x, i + 0.5, 1e-9) << w << "x" << h << " texel " << i << "," << j;
                ASSERT_NEAR(t.y, j + 0.5, 1e-9) << w << "x" << h << " texel " << i << "," << j;
            }
        }
    }
}

TEST(Equirect, AxesFollowTheConventions) {
    // Image centre (u = v = 0.5) looks along -Z.
    const glm::dvec3 centre = direction_from_angles(0.5 * kPi, kTwoPi * 0.5 - kPi);
    EXPECT_NEAR(centre.x, 0.0, 1e-15);
    EXPECT_NEAR(centre.y, 0.0, 1e-15);
    EXPECT_NEAR(centre.z, -1.0, 1e-15);
    const TexelCoord tc = direction_to_texel({0, 0, -1}, 300, 200);
    EXPECT_NEAR(tc.x, 150.0, 1e-12);
    EXPECT_NEAR(tc.y, 100.0, 1e-12);

    // u = 0.75 looks along +X.
    const glm::dvec3 right = direction_from_angles(0.5 * kPi, kTwoPi * 0.75 - kPi);
    EXPECT_NEAR(right.x, 1.0, 1e-15);
    EXPECT_NEAR(right.y, 0.0, 1e-15);
    EXPECT_NEAR(right.z, 0.0, 1e-15);
    const TexelCoord tr = direction_to_texel({1, 0, 0}, 8, 4);
    EXPECT_NEAR(tr.x, 6.0, 1e-12);
    EXPECT_NEAR(tr.y, 2.0, 1e-12);

    // u = 0.25 looks along -X (so the handedness is pinned down, not just the axis).
    const TexelCoord tl = direction_to_texel({-1, 0, 0}, 8, 4);
    EXPECT_NEAR(tl.x, 2.0, 1e-12);

    // Row 0 is near +Y, the last row near -Y.
    for (int i = 0; i < 8; ++i) {
        EXPECT_GT(texel_direction(i, 0, 8, 4).y, 0.9);
        EXPECT_LT(texel_direction(i, 3, 8, 4).y, -0.9);
    }
    EXPECT_NEAR(direction_to_texel({0, 1, 0}, 8, 4).y, 0.0, 1e-12);
    EXPECT_NEAR(direction_to_texel({0, -1, 0}, 8, 4).y, 4.0, 1e-12);
}

TEST(Equirect, SeamDirectionsMapIntoTheHalfOpenRange) {
    // +Z is phi = +pi (atan2(0, -1)), the same column boundary as phi = -pi: x must be 0, not W.
    for (const auto& [w, h] : kSizes) {
        for (const glm::dvec3& d :
             {glm::dvec3{0, 0, 1}, glm::dvec3{-0.0, 0, 1}, glm::dvec3{0, 0.6, 0.8}, glm::dvec3{-0.0, -0.6, 0.8}}) {
            const TexelCoord t = direction_to_texel(d, w, h);
            EXPECT_GE(t.x, 0.0) << w << "x" << h;
            EXPECT_LT(t.x, double(w)) << w << "x" << h;
            EXPECT_NEAR(t.x, 0.0, 1e-12) << w << "x" << h;
        }
        // Just right of the seam is a tiny x, just left of it is just below W.
        const double dx = 1e-9 * w / kTwoPi;
        EXPECT_NEAR(direction_to_texel(direction_from_angles(1.0, -kPi + 1e-9), w, h).x, dx, 1e-10);
        EXPECT_NEAR(direction_to_texel(direction_from_angles(1.0, kPi - 1e-9), w, h).x, w - dx,
                    1e-10);
    }
}

TEST(Equirect, RowSolidAnglesSumToFourPiAndMatchTheFormula) {
    for (const auto& [w, h] : kSizes) {
        const std::vector<double> omega = row_solid_angles(w, h);
        ASSERT_EQ(omega.size(), std::size_t(h));
        double sum = 0;
        for (int j = 0; j < h; ++j) {
            const double analytic =
                (kTwoPi / w) * (std::cos(kPi * j / h) - std::cos(kPi * (j + 1) / h));
            EXPECT_NEAR(omega[std::size_t(j)], analytic, 1e-14) << w << "x" << h << " row " << j;
            EXPECT_DOUBLE_EQ(row_solid_angle(j, w, h), omega[std::size_t(j)]);
            EXPECT_GT(omega[std::size_t(j)], 0.0);
            sum += w * omega[std::size_t(j)];
        }
        EXPECT_NEAR(sum, 4.0 * kPi, 1e-12) << w << "x" << h;
    }
}

TEST(Equirect, RowSolidAnglesAreSymmetricAboutTheEquator) {
    const std::vector<double> omega = row_solid_angles(300, 200);
    for (int j = 0; j < 100; ++j)
        EXPECT_NEAR(omega[std::size_t(j)], omega[std::size_t(199 - j)], 1e-17);
}

HdrImage ramp_image(int w, int h) {
    HdrImage img(w, h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i)
            img.set(i, j, {float(i + 1), float(10 * (j + 1)), float(100 + i * h + j)});
    return img;
}

TEST(Equirect, BilinearAtTexelCentresReturnsTheTexel) {
    const HdrImage img = ramp_image(8, 4);
    for (int j = 0; j < 4; ++j) {
        for (int i = 0; i < 8; ++i) {
            const Rgb c = sample_bilinear(img, texel_direction(i, j, 8, 4));
            const Rgb e = img.at(i, j);
            EXPECT_NEAR(c.r, e.r, 1e-4);
            EXPECT_NEAR(c.g, e.g, 1e-4);
            EXPECT_NEAR(c.b, e.b, 1e-4);
        }
    }
}

TEST(Equirect, BilinearInterpolatesBetweenNeighbours) {
    const HdrImage img = ramp_image(8, 4);
    // Halfway between the centres of columns 2 and 3 on row 1's centre.
    const Rgb c = sample_bilinear(img, direction_from_angles(kPi * 1.5 / 4, kTwoPi * 3.0 / 8 - kPi));
    EXPECT_NEAR(c.r, 0.5 * (3 + 4), 1e-4);
    EXPECT_NEAR(c.g, 20.0, 1e-4);
}

TEST(Equirect, BilinearWrapsAcrossTheSeam) {
    const HdrImage img = ramp_image(8, 4);
    for (int j = 0; j < 4; ++j) {
        const double theta = row_theta(j, 4);
        // phi = -pi and phi = +pi are the seam, exactly between column 7 and column 0.
        for (double phi : {-kPi, kPi}) {
            const Rgb c = sample_bilinear(img, direction_from_angles(theta, phi));
            EXPECT_NEAR(c.r, 0.5 * (img.at(7, j).r + img.at(0, j).r), 1e-4) << "phi " << phi;
            EXPECT_NEAR(c.b, 0.5 * (img.at(7, j).b + img.at(0, j).b), 1e-4) << "phi " << phi;
        }
        // A quarter texel left of the seam is 3/4 column 7, 1/4 column 0.
        const Rgb q = sample_bilinear(img, direction_from_angles(theta, kPi - 0.25 * kTwoPi / 8));
        EXPECT_NEAR(q.r, 0.75 * img.at(7, j).r + 0.25 * img.at(0, j).r, 1e-4);
        // A quarter texel right of it is 1/4 column 7, 3/4 column 0.
        const Rgb p = sample_bilinear(img, direction_from_angles(theta, -kPi + 0.25 * kTwoPi / 8));
        EXPECT_NEAR(p.r, 0.25 * img.at(7, j).r + 0.75 * img.at(0, j).r, 1e-4);
    }
}

TEST(Equirect, BilinearClampsAtThePoles) {
    HdrImage img(8, 4);
    for (int i = 0; i < 8; ++i) {
        img.set(i, 0, {1, 1, 1});
        img.set(i, 1, {5, 5, 5});
        img.set(i, 2, {7, 7, 7});
        img.set(i, 3, {3, 3, 3});
    }
    // Above row 0's centre and below row 3's centre nothing is blended in.
    for (double phi : {-3.0, -1.0, 0.0, 0.5, 2.9}) {
        EXPECT_FLOAT_EQ(sample_bilinear(img, {0, 1, 0}).r, 1.0f);
        EXPECT_FLOAT_EQ(sample_bilinear(img, direction_from_angles(0.05, phi)).g, 1.0f);
        EXPECT_FLOAT_EQ(sample_bilinear(img, {0, -1, 0}).r, 3.0f);
        EXPECT_FLOAT_EQ(sample_bilinear(img, direction_from_angles(kPi - 0.05, phi)).b, 3.0f);
    }
}

TEST(Equirect, ResampleOfAConstantIsTheConstant) {
    HdrImage img(300, 200);
    for (int j = 0; j < 200; ++j)
        for (int i = 0; i < 300; ++i) img.set(i, j, {0.1f, 2.5f, 1234.5f});
    for (const auto& [w, h] : std::vector<std::pair<int, int>>{{8, 4}, {64, 32}, {301, 151}, {7, 3}}) {
        const HdrImage r = resample_bilinear(img, w, h);
        ASSERT_EQ(r.width(), w);
        ASSERT_EQ(r.height(), h);
        for (int j = 0; j < h; ++j) {
            for (int i = 0; i < w; ++i) {
                const Rgb c = r.at(i, j);
                ASSERT_EQ(c.r, 0.1f);
                ASSERT_EQ(c.g, 2.5f);
                ASSERT_EQ(c.b, 1234.5f);
            }
        }
    }
}

TEST(Equirect, ResampleToTheSameSizeIsIdentity) {
    const HdrImage img = ramp_image(8, 4);
    const HdrImage r = resample_bilinear(img, 8, 4);
    EXPECT_EQ(r.data(), img.data());
}

TEST(Equirect, ResampleUpThenAtCentresMatchesBilinearLookup) {
    const HdrImage img = ramp_image(8, 4);
    const HdrImage r = resample_bilinear(img, 16, 8);
    for (int j = 0; j < 8; ++j)
        for (int i = 0; i < 16; ++i) {
            const Rgb e = sample_bilinear(img, texel_direction(i, j, 16, 8));
            EXPECT_FLOAT_EQ(r.at(i, j).r, e.r);
            EXPECT_FLOAT_EQ(r.at(i, j).b, e.b);
        }
}

}  // namespace
}  // namespace glint
