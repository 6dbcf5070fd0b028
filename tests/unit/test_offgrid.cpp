// The off-grid judge (appliance/convolution/offgrid.hpp): exact_at against the exact
// method at texel centres and against values known from outside the code (constants,
// nearest texel), and the Monte Carlo error estimate against a dense quadrature.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/offgrid.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::convolution {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

HdrImage random_map(int w, int h, unsigned seed) {
    std::mt19937 rng(seed);
    std::lognormal_distribution<double> radiance(0.0, 1.0);
    HdrImage img(w, h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) img.set(i, j, {float(radiance(rng)), float(radiance(rng)), float(radiance(rng))});
    return img;
}

// A smooth function of direction: no feature smaller than the whole sphere.
HdrImage smooth_map(int w, int h) {
    HdrImage img(w, h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const glm::dvec3 d = texel_direction(i, j, w, h);
            const double v = 1.0 + 0.5 * d.x + 0.3 * d.y * d.y - 0.2 * d.z;
            img.set(i, j, {float(v), float(1.2 * v - 0.3 * d.y), float(0.8 * v + 0.1 * d.x)});
        }
    return img;
}

// One bright texel on a dim background.
HdrImage bright_texel_map(int w, int h, int bi, int bj) {
    HdrImage img(w, h);
    for (float& v : img.data()) v = 0.05f;
    img.set(bi, bj, {500.0f, 400.0f, 300.0f});
    return img;
}

HdrImage exact_map(const HdrImage& env, double n, int w, int h) {
    Options o;
    o.method = Method::Exact;
    o.threads = 2;
    MapRequest req = MapRequest::make_phong(n, "x");
    req.size = Size{w, h};
    return convolve(env, {req}, o).at(0).image;
}

glm::dvec3 random_direction(std::mt19937& rng) {
    std::normal_distribution<double> g;
    for (;;) {
        const glm::dvec3 d{g(rng), g(rng), g(rng)};
        const double l = glm::length(d);
        if (l > 1e-6) return d / l;
    }
}

TEST(OffGrid, ExactAtTexelCentresMatchesTheExactMethod) {
    // The exact method sums in double and rounds to float once (<= 2^-24 relative);
    // the judge's double value must round to the same float within 1e-9 relative more.
    double worst = 0;
    long long bit_identical = 0, compared = 0;
    for (const HdrImage& env : {random_map(16, 8, 7), random_map(32, 16, 8)}) {
        for (double n : {1.0, 2.5, 10.0, 300.0, 2000.0, 1e5}) {
            for (const Size out : {Size{env.width(), env.height()}, Size{24, 12}, Size{13, 7}}) {
                const HdrImage got = exact_map(env, n, out.width, out.height);
                const ExactAt judge(env, n);
                for (int j = 0; j < out.height; ++j)
                    for (int i = 0; i < out.width; ++i) {
                        const glm::dvec3 e = judge(texel_direction(i, j, out.width, out.height));
                        const Rgb g = got.at(i, j);
                        const double gv[3] = {g.r, g.g, g.b};
                        for (int c = 0; c < 3; ++c) {
                            const double rel = std::abs(gv[c] - e[c]) / e[c];
                            worst = std::max(worst, rel);
                            ++compared;
                            if (float(e[c]) == float(gv[c])) ++bit_identical;
                            ASSERT_LE(rel, 0x1.0p-24 * (1 + 1e-9) + 1e-9)
                                << env.width() << "x" << env.height() << " n " << n << " -> " << out.width << "x"
                                << out.height << " texel " << i << "," << j << " channel " << c;
                        }
                    }
            }
        }
    }
    std::printf("[  report  ] exact_at vs exact: worst relative %.3e, %lld of %lld floats identical\n", worst,
                bit_identical, compared);
    // Two double sums that agree to ~1e-13 would round to the same float nearly always. Measured
    // 25116 of 25164: the others are all at 24x12 with n = 2000 and 1e5, where the judge is within
    // 1e-13 of a long double sum (LongDoubleSum below) and `exact` rounds the other way, so its own
    // double sums carry ~1e-9 relative there (a cosine or power less precise than the judge's).
    EXPECT_GE(double(bit_identical), 0.99 * double(compared));
}

// The conventions' sum in long double with powl, every texel, no cut-off: the judge's cut-offs
// (rows, columns, weights below 1e-300) and its binary powers must not show.
TEST(OffGrid, ExactAtMatchesALongDoubleSumOffGrid) {
    const long double pi = 3.141592653589793238462643383279502884L;
    const HdrImage env = random_map(16, 8, 21);
    std::mt19937 rng(4);
    double worst = 0;
    for (double n : {0.0, 1.0, 2.5, 40.0, 2000.0, 1e5}) {
        const ExactAt judge(env, n);
        // Random directions, and the seam (phi = +-pi, +Z) and the poles, where the column runs wrap.
        std::vector<glm::dvec3> dirs{glm::normalize(glm::dvec3{1e-3, 0.2, 1}), glm::normalize(glm::dvec3{-1e-3, -0.4, 1}),
                                     glm::normalize(glm::dvec3{0.3, 0.1, 1}), {0, 1, 0}, {0, -1, 0},
                                     glm::normalize(glm::dvec3{1e-4, 1, 2e-4})};
        for (int k = 0; k < 50; ++k) dirs.push_back(random_direction(rng));
        for (const glm::dvec3& d : dirs) {
            long double cmax = -2, num = 0, den = 0;
            for (int pass = 0; pass < 2; ++pass)
                for (int j = 0; j < 8; ++j)
                    for (int i = 0; i < 16; ++i) {
                        const long double t = pi * (j + 0.5L) / 8, p = 2 * pi * (i + 0.5L) / 16 - pi;
                        const long double c = d.x * sinl(t) * sinl(p) + d.y * cosl(t) - d.z * sinl(t) * cosl(p);
                        if (pass == 0) {
                            cmax = std::max(cmax, c);
                            continue;
                        }
                        if (!(c > 0)) continue;
                        const long double a = pi * j / 8, b = pi * (j + 1) / 8;
                        const long double f = powl(c / cmax, (long double)n) * 2 * sinl(0.5L * (a + b)) * sinl(0.5L * (b - a));
                        num += f * env.at(i, j).g;
                        den += f;
                    }
            const double ref = double(num / den);
            const double rel = std::abs(judge(d).y - ref) / ref;
            worst = std::max(worst, rel);
            EXPECT_LE(rel, 1e-11) << "n " << n << " direction " << d.x << "," << d.y << "," << d.z;
        }
    }
    std::printf("[  report  ] exact_at vs long double sum: worst relative %.2e\n", worst);
}

TEST(OffGrid, ConstantEnvironmentGivesTheConstant) {
    std::mt19937 rng(3);
    for (const Size size : {Size{8, 4}, Size{33, 17}}) {
        HdrImage env(size.width, size.height);
        for (int j = 0; j < size.height; ++j)
            for (int i = 0; i < size.width; ++i) env.set(i, j, {0.5f, 2.0f, 7.0f});
        for (double n : {0.0, 1.0, 1e7, kInf}) {
            const ExactAt judge(env, n);
            std::vector<glm::dvec3> dirs{{0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {1, 0, 0}};
            for (int k = 0; k < 200; ++k) dirs.push_back(random_direction(rng));
            for (const glm::dvec3& d : dirs) {
                const glm::dvec3 e = judge(d);
                EXPECT_NEAR(e.x, 0.5, 0.5 * 1e-12) << "n " << n;
                EXPECT_NEAR(e.y, 2.0, 2.0 * 1e-12) << "n " << n;
                EXPECT_NEAR(e.z, 7.0, 7.0 * 1e-12) << "n " << n;
            }
        }
    }
}

TEST(OffGrid, HugeExponentOnATinyMapGivesTheNearestTexel) {
    const HdrImage env = random_map(8, 4, 11);
    const ExactAt judge(env, 1e7);
    std::mt19937 rng(5);
    int checked = 0;
    for (int k = 0; k < 2000; ++k) {
        const glm::dvec3 d = random_direction(rng);
        double best = -2, second = -2;
        int bi = 0, bj = 0;
        for (int j = 0; j < 4; ++j)
            for (int i = 0; i < 8; ++i) {
                const double c = glm::dot(d, texel_direction(i, j, 8, 4));
                if (c > best) {
                    second = best;
                    best = c;
                    bi = i;
                    bj = j;
                } else {
                    second = std::max(second, c);
                }
            }
        const glm::dvec3 e = judge(d);
        ASSERT_TRUE(std::isfinite(e.x) && std::isfinite(e.y) && std::isfinite(e.z));
        // (second / best)^1e7 < 1e-40 unless the two are within ~1e-5: a tie, not compared.
        if (best - second < 1e-5) continue;
        ++checked;
        const Rgb l = env.at(bi, bj);
        EXPECT_NEAR(e.x, l.r, 1e-12 * l.r);
        EXPECT_NEAR(e.y, l.g, 1e-12 * l.g);
        EXPECT_NEAR(e.z, l.b, 1e-12 * l.b);
    }
    EXPECT_GT(checked, 1900);
    // The poles themselves: every texel of the first row is equally near; their mean.
    const glm::dvec3 top = judge({0, 1, 0});
    double mean = 0;
    for (int i = 0; i < 8; ++i) mean += env.at(i, 0).r / 8.0;
    EXPECT_NEAR(top.x, mean, 1e-6 * mean);
}

TEST(OffGrid, MirrorIsTheBilinearEnvironment) {
    const HdrImage env = random_map(16, 8, 12);
    std::mt19937 rng(6);
    for (int k = 0; k < 100; ++k) {
        const glm::dvec3 d = random_direction(rng);
        const Rgb s = sample_bilinear(env, d);
        const Rgb e = exact_at(env, kInf, d);
        EXPECT_EQ(s.r, e.r);
        EXPECT_EQ(s.g, e.g);
        EXPECT_EQ(s.b, e.b);
    }
    const OffGridError e = measure_offgrid_error(env, env, kInf, 256, 1, 2);
    EXPECT_EQ(e.weighted_relative_rms, 0.0);
    EXPECT_EQ(e.worst_texel, 0.0);
    EXPECT_EQ(e.samples, 256);
}

// The lobe lookup (core/equirect.hpp, sample_lobe) is the conventions' sum itself: against the
// judge's sum over every texel in double, at random directions, at and near both poles, on both
// sides of the seam and on texel edges, for lobes from wide (it then visits most of the map) to
// far narrower than a texel.
TEST(OffGrid, LobeLookupIsTheExactSum) {
    std::mt19937 rng(11);
    std::vector<glm::dvec3> dirs = {{0, 1, 0},       {0, -1, 0},          {1e-4, 1, 0},     {1e-3, -1, 5e-4},
                                    {1e-6, 0.3, 1},  {-1e-6, 0.3, 1},     {0, 0, -1},       {1, 0, 0}};
    dirs.push_back(direction_from_angles(kPi * 5.0 / 32, kTwoPi * 7.0 / 64 - kPi));  // a texel corner
    dirs.push_back(direction_from_angles(kPi * 16.5 / 32, kTwoPi * 20.0 / 64 - kPi));  // a column edge
    for (int k = 0; k < 150; ++k) dirs.push_back(random_direction(rng));
    for (const HdrImage& env : {bright_texel_map(64, 32, 40, 12), random_map(64, 32, 5)})
        for (const double n : {50.0, 500.0, 5000.0, 1e6, 1e7}) {
            const ExactAt judge(env, n);
            for (const glm::dvec3& d : dirs) {
                const Rgb a = sample_lobe(env, d, n);
                const glm::dvec3 b = judge(d);
                for (int c = 0; c < 3; ++c) {
                    const double av = c == 0 ? a.r : c == 1 ? a.g : a.b;
                    ASSERT_NEAR(av, b[c], 1e-6 * std::max(std::abs(b[c]), 1e-3))
                        << "n " << n << " at " << d.x << ", " << d.y << ", " << d.z << " channel " << c;
                }
            }
        }
}

TEST(OffGrid, SmoothMapAtAGenerousSizeIsSmall) {
    const HdrImage env = smooth_map(64, 32);
    for (double n : {1.0, 10.0}) {
        const HdrImage map = exact_map(env, n, 64, 32);
        const OffGridError e = measure_offgrid_error(env, map, n, 2048, 42, 2);
        std::printf("[  report  ] smooth 64x32 n %g at 64x32: off-grid rms %.2e +- %.1e, worst %.2e\n", n,
                    e.weighted_relative_rms, e.rms_standard_error, e.worst_texel);
        EXPECT_LT(e.weighted_relative_rms, 2e-3) << "n " << n;
        EXPECT_LT(e.worst_texel, 1e-2) << "n " << n;
        EXPECT_GT(e.mean_abs_reference, 0.5);
    }
}

TEST(OffGrid, MapTooCoarseForItsLobeIsLarge) {
    const HdrImage env = bright_texel_map(64, 32, 40, 12);
    const HdrImage map = exact_map(env, 2000, 16, 8);
    const OffGridError e = measure_offgrid_error(env, map, 2000, 2048, 42, 2);
    std::printf("[  report  ] bright texel 64x32 n 2000 at 16x8: off-grid rms %.3f +- %.3f, worst %.3f\n",
                e.weighted_relative_rms, e.rms_standard_error, e.worst_texel);
    EXPECT_GT(e.weighted_relative_rms, 0.05);
    EXPECT_GT(e.worst_texel, 0.05);
    // The worst sample lies near the bright texel (theta 1.23, phi 2.36 at texel 40, 12).
    const glm::dvec3 sun = texel_direction(40, 12, 64, 32);
    EXPECT_GT(glm::dot(e.worst_direction, sun), std::cos(0.5));
}

TEST(OffGrid, ResultDoesNotDependOnTheThreadCount) {
    const HdrImage env = bright_texel_map(32, 16, 5, 3);
    const HdrImage map = exact_map(env, 40, 24, 12);
    const OffGridError one = measure_offgrid_error(env, map, 40, 501, 9, 1);
    for (int threads : {2, 3}) {
        const OffGridError many = measure_offgrid_error(env, map, 40, 501, 9, threads);
        EXPECT_EQ(one.weighted_relative_rms, many.weighted_relative_rms) << threads;
        EXPECT_EQ(one.rms_standard_error, many.rms_standard_error) << threads;
        EXPECT_EQ(one.worst_texel, many.worst_texel) << threads;
        EXPECT_EQ(one.mean_abs_reference, many.mean_abs_reference) << threads;
        EXPECT_EQ(one.worst_direction, many.worst_direction) << threads;
    }
    // A different seed gives different samples.
    const OffGridError other = measure_offgrid_error(env, map, 40, 501, 10, 2);
    EXPECT_NE(one.weighted_relative_rms, other.weighted_relative_rms);
}

// sqrt(sum dOmega |A-B|^2 / sum dOmega |B|^2) by the midpoint rule on a fine grid.
double dense_estimate(const HdrImage& env, const HdrImage& map, double n, int w, int h) {
    const ExactAt judge(env, n);
    double diff = 0, ref = 0;
    for (int j = 0; j < h; ++j) {
        const double omega = row_solid_angle(j, w, h);
        for (int i = 0; i < w; ++i) {
            const glm::dvec3 d = texel_direction(i, j, w, h);
            const Rgb a = sample_bilinear(map, d);
            const glm::dvec3 b = judge(d);
            const glm::dvec3 e = glm::dvec3{a.r, a.g, a.b} - b;
            diff += omega * glm::dot(e, e);
            ref += omega * glm::dot(b, b);
        }
    }
    return std::sqrt(diff / ref);
}

TEST(OffGrid, MixtureEstimateAgreesWithADenseQuadrature) {
    // A bright texel that dominates both integrals, and a map too coarse for it.
    const HdrImage env = bright_texel_map(32, 16, 21, 5);
    for (double n : {40.0, 300.0}) {
        const HdrImage map = exact_map(env, n, 16, 8);
        const double dense = dense_estimate(env, map, n, 512, 256);
        const OffGridError e = measure_offgrid_error(env, map, n, 4096, 77, 2);
        std::printf("[  report  ] n %g: dense %.4f, mixture %.4f +- %.4f\n", n, dense, e.weighted_relative_rms,
                    e.rms_standard_error);
        EXPECT_LT(e.rms_standard_error, 0.1 * e.weighted_relative_rms) << "n " << n;
        // 4 standard errors, and 1 % for the quadrature's own error.
        EXPECT_NEAR(e.weighted_relative_rms, dense, 4 * e.rms_standard_error + 0.01 * dense) << "n " << n;
    }
}

TEST(OffGrid, RejectsUnusableInput) {
    const HdrImage env = random_map(8, 4, 1);
    EXPECT_THROW(ExactAt(HdrImage{}, 1.0), InputError);
    EXPECT_THROW(ExactAt(env, -1.0), InputError);
    EXPECT_THROW(ExactAt(env, std::nan("")), InputError);
    EXPECT_THROW(exact_at(env, 1.0, {0, 0, 0}), InputError);
    EXPECT_THROW(measure_offgrid_error(env, env, 1.0, 0, 1, 1), InputError);
    EXPECT_THROW(measure_offgrid_error(env, HdrImage{}, 1.0, 10, 1, 1), InputError);
}

}  // namespace
}  // namespace glint::convolution
