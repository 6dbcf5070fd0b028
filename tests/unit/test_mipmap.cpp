// Tests of the solid-angle pyramid and the thesis' MIP-mapping baseline (convolution/mipmap).
#include <gtest/gtest.h>

#include "tests/unit/test_support.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <utility>
#include <vector>

#include "appliance/convolution/mipmap.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"

namespace glint::convolution {
namespace {

using glint::testing::constant_map;

HdrImage noise(int w, int h, unsigned seed) {
    HdrImage img(w, h);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> dist(0.0f, 1.0f);
    // A few very bright texels, as in a real sky, so that weighting errors show.
    for (float& v : img.data()) v = dist(rng) < 0.001f ? 5000.0f * dist(rng) : dist(rng);
    return img;
}

std::array<double, 3> energy(const HdrImage& img) {
    const std::vector<double> omega = row_solid_angles(img.width(), img.height());
    std::array<double, 3> sum{0, 0, 0};
    for (int j = 0; j < img.height(); ++j)
        for (int i = 0; i < img.width(); ++i) {
            const Rgb c = img.at(i, j);
            sum[0] += double(c.r) * omega[std::size_t(j)];
            sum[1] += double(c.g) * omega[std::size_t(j)];
            sum[2] += double(c.b) * omega[std::size_t(j)];
        }
    return sum;
}

// Odd sides round up (each coarse texel the solid-angle mean of the parts of the finer texels
// under it), down to a height of 1: until 2026-12-06 the chain stopped at the first odd side,
// and a 999x500 input had no coarser level at all.
TEST(Pyramid, LevelSizesHalveRoundingUpToAHeightOfOne) {
    const std::vector<std::pair<std::pair<int, int>, std::vector<std::pair<int, int>>>> cases = {
        {{300, 200}, {{300, 200}, {150, 100}, {75, 50}, {38, 25}, {19, 13}, {10, 7}, {5, 4}, {3, 2}, {2, 1}}},
        {{8, 4}, {{8, 4}, {4, 2}, {2, 1}}},
        {{12, 6}, {{12, 6}, {6, 3}, {3, 2}, {2, 1}}},
        {{7, 3}, {{7, 3}, {4, 2}, {2, 1}}},
        {{2, 1}, {{2, 1}}},
        {{4, 4}, {{4, 4}, {2, 2}, {1, 1}}},
    };
    for (const auto& [size, expected] : cases) {
        const Pyramid p(HdrImage(size.first, size.second));
        ASSERT_EQ(p.levels(), int(expected.size())) << size.first << "x" << size.second;
        for (int k = 0; k < p.levels(); ++k) {
            EXPECT_EQ(p.level(k).width(), expected[std::size_t(k)].first);
            EXPECT_EQ(p.level(k).height(), expected[std::size_t(k)].second);
        }
    }
    const Pyramid big(HdrImage(1024, 512));
    EXPECT_EQ(big.levels(), 10);  // 1024x512 ... 2x1
    EXPECT_EQ(big.level(9).width(), 2);
    EXPECT_EQ(big.level(9).height(), 1);
    EXPECT_THROW(big.level(10), std::out_of_range);
    EXPECT_THROW(big.level(-1), std::out_of_range);
    EXPECT_THROW(Pyramid{HdrImage()}, InputError);
}

TEST(Pyramid, ConstantStaysConstantAtEveryLevel) {
    const Rgb c{0.3f, 1.7f, 42.0f};
    for (const auto& [w, h] : {std::pair{64, 32}, std::pair{300, 200}, std::pair{8, 4}}) {
        const Pyramid p(constant_map(w, h, c));
        for (int k = 0; k < p.levels(); ++k)
            for (int j = 0; j < p.level(k).height(); ++j)
                for (int i = 0; i < p.level(k).width(); ++i) {
                    const Rgb v = p.level(k).at(i, j);
                    ASSERT_EQ(v.r, c.r) << "level " << k;
                    ASSERT_EQ(v.g, c.g) << "level " << k;
                    ASSERT_EQ(v.b, c.b) << "level " << k;
                }
    }
}

TEST(Pyramid, EveryLevelPreservesTheSolidAngleWeightedSum) {
    for (const auto& [w, h] : {std::pair{256, 128}, std::pair{300, 200}, std::pair{24, 12}}) {
        const HdrImage input = noise(w, h, unsigned(w));
        const std::array<double, 3> e0 = energy(input);
        const Pyramid p(input);
        ASSERT_GT(p.levels(), 1);
        for (int k = 1; k < p.levels(); ++k) {
            const std::array<double, 3> ek = energy(p.level(k));
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(ek[std::size_t(c)], e0[std::size_t(c)], 1e-6 * e0[std::size_t(c)])
                    << w << "x" << h << " level " << k << " channel " << c;
        }
    }
}

TEST(Pyramid, ChildrenAreWeightedByTheirSolidAngles) {
    // 2x4 -> 1x2. Rows 0 and 1 of the 2x4 map hold pi(1 - s) and pi s per texel,
    // s = sqrt(2)/2, so the coarse texel is ((1 - s)(a0 + a1) + s(b0 + b1)) / 2,
    // not the plain average (a0 + a1 + b0 + b1) / 4.
    HdrImage img(2, 4);
    img.set(0, 0, {1, 0, 0});
    img.set(1, 0, {1, 0, 0});
    img.set(0, 1, {3, 0, 0});
    img.set(1, 1, {3, 0, 0});
    img.set(0, 2, {0, 5, 0});
    img.set(1, 2, {0, 7, 0});
    const Pyramid p(img);
    ASSERT_EQ(p.levels(), 3);  // 2x4, 1x2, 1x1
    const double s = std::sqrt(2.0) / 2.0;
    EXPECT_NEAR(p.level(1).at(0, 0).r, ((1 - s) * 2 + s * 6) / 2, 1e-6);
    EXPECT_NEAR(p.level(1).at(0, 0).g, 0.0, 1e-7);
    // Row 2 is the equatorial row of the lower pair: weight s of the pair's total.
    EXPECT_NEAR(p.level(1).at(0, 1).g, s * 12 / 2, 1e-6);
    EXPECT_NEAR(p.level(1).at(0, 1).r, 0.0, 1e-7);
}

TEST(MipmapLevel, FollowsTheThesisFormulas) {
    // 1024x512: l_max = log2(512) = 9, irradiance at l_max - 2 = 7 (4 rows).
    EXPECT_DOUBLE_EQ(mipmap_level(512, true, 1.0), 7.0);
    EXPECT_DOUBLE_EQ(mipmap_level(512, true, 5000.0), 7.0);  // shininess does not matter
    EXPECT_DOUBLE_EQ(mipmap_level(512, false, 0.0), 7.0);    // s/2 clamped up to 4
    EXPECT_DOUBLE_EQ(mipmap_level(512, false, 8.0), 7.0);
    EXPECT_DOUBLE_EQ(mipmap_level(512, false, 16.0), 6.0);
    EXPECT_DOUBLE_EQ(mipmap_level(512, false, 64.0), 4.0);
    EXPECT_DOUBLE_EQ(mipmap_level(512, false, 1024.0), 0.0);
    EXPECT_DOUBLE_EQ(mipmap_level(512, false, 20480.0), 0.0);  // s/2 clamped down to H
    EXPECT_NEAR(mipmap_level(512, false, 24.0), 9.0 - std::log2(12.0), 1e-15);
    EXPECT_NEAR(mipmap_level(200, true, 1.0), std::log2(200.0) - 2.0, 1e-15);
}

TEST(MipmapLevel, ShrinksWithShininess) {
    double previous = mipmap_level(512, false, 0.0);
    for (double s = 1.0; s <= 4096.0; s *= 1.5) {
        const double l = mipmap_level(512, false, s);
        EXPECT_LE(l, previous) << "s " << s;
        if (s > 8.0 && s < 1024.0) {
            EXPECT_LT(l, previous) << "s " << s;
        }
        previous = l;
    }
}

// Built on demand (engine: SH plans read only level 0), the levels are those of the eager build,
// in any order of asking; a released level 0 leaves the coarser ones readable.
TEST(Pyramid, OnDemandLevelsEqualTheEagerOnesInAnyOrder) {
    const HdrImage input = noise(128, 64, 17);
    const Pyramid eager(input);
    const Pyramid lazy(input, 2, Pyramid::Build::OnDemand);
    ASSERT_EQ(lazy.levels(), eager.levels());
    for (int k : {3, 1, 6, 0, 2, 5, 4}) {
        const HdrImage& a = lazy.level(k);
        const HdrImage& b = eager.level(k);
        ASSERT_EQ(a.width(), b.width());
        ASSERT_EQ(a.data(), b.data()) << "level " << k;
    }
    Pyramid released(input, 1, Pyramid::Build::OnDemand);
    released.release_level(0);
    EXPECT_TRUE(released.released(0));
    EXPECT_THROW((void)released.level(0), std::logic_error);
    EXPECT_EQ(released.level(5).data(), eager.level(5).data());
    // Released with no coarser level to be read: none is built, and asking for one is a bug.
    Pyramid done(input, 1, Pyramid::Build::OnDemand);
    done.release_level(0, false);
    EXPECT_THROW((void)done.level(2), std::logic_error);
}

TEST(MipmapConvolve, IrradianceOfA1024x512MapReadsTheFourRowLevel) {
    const Pyramid p(noise(1024, 512, 11));
    ASSERT_EQ(p.level(7).height(), 4);
    ASSERT_EQ(p.level(7).width(), 8);
    const HdrImage out = mipmap_convolve(p, true, 1.0, 32, 16);
    for (int j = 0; j < 16; ++j)
        for (int i = 0; i < 32; ++i) {
            const Rgb e = sample_bilinear(p.level(7), texel_direction(i, j, 32, 16));
            const Rgb v = out.at(i, j);
            ASSERT_EQ(v.r, e.r);
            ASSERT_EQ(v.g, e.g);
            ASSERT_EQ(v.b, e.b);
        }
}

TEST(MipmapConvolve, FractionalLevelsBlendTheTwoNeighbours) {
    const Pyramid p(noise(64, 32, 5));
    const double level = mipmap_level(32, false, 24.0);  // 5 - log2(12) = 1.415
    ASSERT_GT(level, 1.0);
    ASSERT_LT(level, 2.0);
    const double t = level - 1.0;
    const HdrImage out = mipmap_convolve(p, false, 24.0, 20, 10);
    for (int j = 0; j < 10; ++j)
        for (int i = 0; i < 20; ++i) {
            const glm::dvec3 d = texel_direction(i, j, 20, 10);
            const Rgb a = sample_bilinear(p.level(1), d);
            const Rgb b = sample_bilinear(p.level(2), d);
            const double er = (1 - t) * a.r + t * b.r;
            const double eb = (1 - t) * a.b + t * b.b;
            EXPECT_NEAR(out.at(i, j).r, er, 1e-6 * (1 + er));
            EXPECT_NEAR(out.at(i, j).b, eb, 1e-6 * (1 + eb));
        }
}

// (MipmapConvolve.LevelsBeyondTheChainUseTheCoarsestLevel went with the odd halving of
// 2026-12-06: every chain now reaches a height of 1, past every level the thesis' formula asks.)

TEST(MipmapConvolve, MirrorLikeShininessReadsTheInput) {
    const HdrImage input = noise(64, 32, 3);
    const Pyramid p(input);
    const HdrImage out = mipmap_convolve(p, false, 1e6, 64, 32);
    for (std::size_t k = 0; k < out.data().size(); ++k)
        ASSERT_NEAR(out.data()[k], input.data()[k], 1e-3f * (1.0f + input.data()[k]));
}

TEST(MipmapConvolve, ConstantGivesTheConstant) {
    const Rgb c{0.25f, 3.5f, 1000.0f};
    for (const auto& [w, h] : {std::pair{128, 64}, std::pair{300, 200}, std::pair{8, 4}}) {
        const Pyramid p(constant_map(w, h, c));
        for (bool irradiance : {true, false})
            for (double s : {0.0, 1.0, 10.0, 24.0, 100.0, 20480.0})
                for (const auto& [ow, oh] : {std::pair{32, 16}, std::pair{7, 3}}) {
                    const HdrImage out = mipmap_convolve(p, irradiance, s, ow, oh);
                    ASSERT_EQ(out.width(), ow);
                    ASSERT_EQ(out.height(), oh);
                    for (int j = 0; j < oh; ++j)
                        for (int i = 0; i < ow; ++i) {
                            ASSERT_EQ(out.at(i, j).r, c.r);
                            ASSERT_EQ(out.at(i, j).g, c.g);
                            ASSERT_EQ(out.at(i, j).b, c.b);
                        }
                }
    }
}

TEST(MipmapConvolve, HigherShininessKeepsASmallLightSharper) {
    // A small bright patch on black: the sharper the lobe, the finer the level and the
    // higher the peak (the coarse levels spread its energy over larger texels).
    HdrImage input(256, 128);
    for (int j = 62; j < 66; ++j)
        for (int i = 126; i < 130; ++i) input.set(i, j, {100, 100, 100});
    const Pyramid p(input);
    auto peak = [&](double s) {
        const HdrImage out = mipmap_convolve(p, false, s, 64, 32);
        float m = 0;
        for (float v : out.data()) m = std::max(m, v);
        return m;
    };
    const float p8 = peak(8.0), p32 = peak(32.0), p128 = peak(128.0);
    EXPECT_LT(p8, p32);
    EXPECT_LT(p32, p128);
}

TEST(MipmapConvolve, RejectsNegativeOrNaNShininess) {
    const Pyramid p(constant_map(8, 4, {1, 1, 1}));
    EXPECT_THROW(mipmap_convolve(p, false, -1.0, 8, 4), InputError);
    EXPECT_THROW(mipmap_convolve(p, false, std::numeric_limits<double>::quiet_NaN(), 8, 4),
                 InputError);
    EXPECT_THROW(mipmap_convolve(p, false, 1.0, 0, 4), InputError);
    EXPECT_NO_THROW(mipmap_convolve(p, true, -1.0, 8, 4));  // irradiance ignores shininess
}

}  // namespace
}  // namespace glint::convolution
