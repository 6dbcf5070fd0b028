// Output grids (appliance/convolution/output_grid.hpp) and what convolve() delivers with them:
// the lookup-error estimates against measured lookups, 4-point resampling, the bright lobes
// added back exactly, the mirror map's footprint filter, and lobes up to n = 1e7.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/lobe_sum.hpp"
#include "appliance/convolution/methods.hpp"
#include "appliance/convolution/offgrid.hpp"
#include "appliance/convolution/output_grid.hpp"
#include "appliance/convolution/planner.hpp"
#include "appliance/convolution/sh.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/error_metrics.hpp"
#include "appliance/core/errors.hpp"

namespace glint::convolution {
namespace {

// A map holding f(d) at each texel centre.
template <class F>
HdrImage sampled(int w, int h, F f) {
    HdrImage m(w, h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const glm::dvec3 d = texel_direction(i, j, w, h);
            const double v = f(d);
            m.set(i, j, {float(v), float(0.5 * v), float(0.25 * v + 0.1)});
        }
    return m;
}

// Smooth, but not low order: a few broad bumps over a floor.
double smooth_field(const glm::dvec3& d) {
    const glm::dvec3 a = glm::normalize(glm::dvec3(0.3, 0.8, -0.5)), b = glm::normalize(glm::dvec3(-0.7, -0.2, 0.4));
    return 1.0 + 3.0 * std::exp(8.0 * (glm::dot(d, a) - 1.0)) + 2.0 * std::exp(5.0 * (glm::dot(d, b) - 1.0));
}

double weighted_rms(const HdrImage& a, const HdrImage& b) { return compare_maps(a, b).weighted_relative_rms; }

TEST(OutputGrid, ResamplingToTheSameGridIsTheIdentity) {
    const HdrImage m = sampled(48, 24, smooth_field);
    const HdrImage r = resample_cubic(m, {48, 24}, 2);
    ASSERT_EQ(r.data().size(), m.data().size());
    for (std::size_t k = 0; k < m.data().size(); ++k) EXPECT_FLOAT_EQ(r.data()[k], m.data()[k]) << k;
}

// resample_cubic as two whole passes, written out plainly: every input row to the output's
// columns, then down the columns with rows past a pole mirrored and turned half a turn; in
// float, as resample_cubic sums.
HdrImage two_pass_resample(const HdrImage& map, Size out, long long& clamped) {
    const int w = map.width(), h = map.height();
    const auto taps = [](int o, int out_count, int in_count, int& first) {
        const double x = (o + 0.5) * double(in_count) / double(out_count) - 0.5;
        const double base = std::floor(x), t = x - base;
        first = int(base) - 1;
        return std::array<double, 4>{-t * (t - 1.0) * (t - 2.0) / 6.0, (t + 1.0) * (t - 1.0) * (t - 2.0) / 2.0,
                                     -(t + 1.0) * t * (t - 2.0) / 2.0, (t + 1.0) * t * (t - 1.0) / 6.0};
    };
    const auto wrap = [](int i, int n) { return ((i % n) + n) % n; };
    std::vector<std::vector<double>> across(std::size_t(h), std::vector<double>(3 * std::size_t(out.width)));
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < out.width; ++i) {
            int first = 0;
            const auto wt = taps(i, out.width, w, first);
            for (int c = 0; c < 3; ++c) {
                float v = 0;
                for (int k = 0; k < 4; ++k) v += float(wt[std::size_t(k)]) * map.row(j)[3 * wrap(first + k, w) + c];
                across[std::size_t(j)][std::size_t(3 * i + c)] = float(v);
            }
        }
    HdrImage r(out.width, out.height);
    clamped = 0;
    for (int j = 0; j < out.height; ++j) {
        int first = 0;
        const auto wt = taps(j, out.height, h, first);
        for (int i = 0; i < out.width; ++i)
            for (int c = 0; c < 3; ++c) {
                float v = 0;
                for (int k = 0; k < 4; ++k) {
                    int row = first + k, col = i;
                    if (row < 0 || row >= h) {
                        row = row < 0 ? std::min(-1 - row, h - 1) : std::max(2 * h - 1 - row, 0);
                        col = wrap(i + out.width / 2, out.width);
                    }
                    v += float(wt[std::size_t(k)]) * float(across[std::size_t(row)][std::size_t(3 * col + c)]);
                }
                if (v < 0) {
                    v = 0;
                    ++clamped;
                }
                r.row(j)[3 * i + c] = v;
            }
    }
    return r;
}

TEST(OutputGrid, ResamplingIsItsTwoSeparablePassesAtAnySizeAndThreadCount) {
    // resample_cubic makes its first pass band by band (no whole map of it); against the two
    // passes made whole, on spiky data (overshoots clamped) and sizes whose bands cross the
    // poles, odd widths and ratios that are not whole.
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (const auto& [in, out] : std::vector<std::pair<Size, Size>>{
             {{64, 32}, {256, 128}}, {{64, 32}, {100, 50}}, {{31, 15}, {61, 37}}, {{48, 24}, {96, 48}}, {{40, 20}, {40, 20}}, {{1, 6}, {4, 12}}}) {
        HdrImage m(in.width, in.height);
        for (float& v : m.data()) v = float(u(rng) < 0.05 ? 100.0 * u(rng) : u(rng));
        long long expected_clamped = 0;
        const HdrImage expected = two_pass_resample(m, out, expected_clamped);
        for (int threads : {1, 2, 3}) {
            long long clamped = 0;
            const HdrImage r = resample_cubic(m, out, threads, &clamped);
            ASSERT_EQ(r.width(), out.width);
            ASSERT_EQ(r.height(), out.height);
            for (std::size_t k = 0; k < r.data().size(); ++k)
                ASSERT_NEAR(r.data()[k], expected.data()[k], 1e-5 * (1.0 + std::abs(expected.data()[k])))
                    << in.width << "x" << in.height << " -> " << out.width << "x" << out.height << ", value " << k;
            EXPECT_NEAR(double(clamped), double(expected_clamped), 2.0 + 1e-3 * double(expected_clamped));
            if (out.width != in.width && in.width > 1) {  // a one-column map has too few spikes
                EXPECT_GT(expected_clamped, 0) << "the spikes should overshoot between texels";
            }
        }
    }
}

TEST(OutputGrid, ResamplingASmoothMapMatchesSamplingItFinerWithinItsEstimate) {
    // Resampled from 64x32 to 256x128 against the field sampled at 256x128: the error is
    // small and within the estimate's bound (RMS and worst), and the estimate is not vacuous.
    const HdrImage coarse = sampled(64, 32, smooth_field);
    const HdrImage fine = sampled(256, 128, smooth_field);
    const LookupError e = estimate_lookup_error(coarse, 2);
    const HdrImage r = resample_cubic(coarse, {256, 128}, 2);
    const MapError err = compare_maps(r, fine);
    std::printf("[  report  ] resampled 64x32 -> 256x128: rms %.2e (estimate %.2e), worst %.2e (estimate %.2e)\n",
                err.weighted_relative_rms, e.cubic_rms, err.worst_texel, e.cubic_worst);
    EXPECT_LT(err.weighted_relative_rms, 2e-3);
    EXPECT_LE(err.weighted_relative_rms, e.cubic_rms);
    EXPECT_LE(err.worst_texel, e.cubic_worst);
    EXPECT_LT(e.cubic_rms, 20 * err.weighted_relative_rms);
}

TEST(OutputGrid, BilinearEstimateFollowsMeasuredLookups) {
    // The RMS estimate against bilinear lookups of the map at the centres of a 3x finer grid
    // (against the field itself there): same order, and it falls as h^2.
    for (int h : {16, 32, 64}) {
        const HdrImage m = sampled(2 * h, h, smooth_field);
        const LookupError e = estimate_lookup_error(m, 2);
        const HdrImage truth = sampled(6 * h, 3 * h, smooth_field);
        const double real = weighted_rms(resample_bilinear(m, 6 * h, 3 * h), truth);
        std::printf("[  report  ] %dx%d: bilinear lookups rms %.2e, estimate %.2e\n", 2 * h, h, real, e.bilinear_rms);
        EXPECT_GT(e.bilinear_rms, 0.5 * real) << h;
        EXPECT_LT(e.bilinear_rms, 3.0 * real) << h;
    }
}

// The estimates written out plainly, texel by texel and channel by channel: rows continued
// across the poles (mirrored, half a turn round) and columns wrapped at the seam.
LookupError plain_lookup_error(const HdrImage& m) {
    const int w = m.width(), h = m.height();
    const auto wrap = [](int i, int n) { return ((i % n) + n) % n; };
    const auto at = [&](int i, int j, int c) {
        if (j < 0 || j >= h) {
            j = j < 0 ? std::min(-1 - j, h - 1) : std::max(2 * h - 1 - j, 0);
            i += w / 2;
        }
        return double(m.row(j)[3 * wrap(i, w) + c]);
    };
    const std::vector<double> solid = row_solid_angles(w, h);
    double mean = 0;
    for (int j = 0; j < h; ++j)
        for (int k = 0; k < 3 * w; ++k) mean += std::abs(m.row(j)[k]) * solid[std::size_t(j)];
    mean /= 3.0 * 4.0 * kPi;
    double value2 = 0, bilinear2 = 0, cubic2 = 0;
    LookupError e;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i)
            for (int c = 0; c < 3; ++c) {
                const double v = at(i, j, c);
                const double a = at(i - 1, j, c) - 2 * v + at(i + 1, j, c);
                const double b = at(i, j - 1, c) - 2 * v + at(i, j + 1, c);
                const double d4 =
                    std::abs(at(i, j - 2, c) - 4 * at(i, j - 1, c) + 6 * v - 4 * at(i, j + 1, c) + at(i, j + 2, c)) +
                    std::abs(at(i - 2, j, c) - 4 * at(i - 1, j, c) + 6 * v - 4 * at(i + 1, j, c) + at(i + 2, j, c));
                const double floor = std::max(std::abs(v), mean);
                const double sa = solid[std::size_t(j)];
                value2 += sa * v * v;
                bilinear2 += sa * ((a * a + b * b) / 120.0 + a * b / 72.0);
                cubic2 += sa * std::pow(d4 * 3.0 / 128.0, 2);
                if (floor > 0) {
                    e.between_worst = std::max(e.between_worst, (std::abs(a) + std::abs(b)) / 8.0 / floor);
                    e.cubic_worst = std::max(e.cubic_worst, d4 * 3.0 / 128.0 / floor);
                }
                // The poles' clamp: half the step to the value half a turn round, over the cap
                // between the pole and the row's centres.
                for (const int pole : {0, h - 1}) {
                    if (j != pole) continue;
                    const double opposite =
                        w % 2 == 0 ? at(i + w / 2, j, c) : 0.5 * (at(i + w / 2, j, c) + at(i + w / 2 + 1, j, c));
                    const double clamp = 0.5 * std::abs(v - opposite);
                    const double cap = (1 - std::cos(kPi / (2 * h))) / (1 - std::cos(kPi / h));
                    bilinear2 += sa * clamp * clamp / 6.0 * cap;
                    if (floor > 0) e.pole_worst = std::max(e.pole_worst, clamp / floor);
                }
            }
    e.bilinear_worst = std::max(e.between_worst, e.pole_worst);
    if (value2 > 0) {
        e.bilinear_rms = std::sqrt(bilinear2 / value2);
        e.cubic_rms = std::sqrt(cubic2 / value2);
    }
    return e;
}

TEST(OutputGrid, LookupEstimatesMatchTheirPlainFormulas) {
    // estimate_lookup_error sums in vector lanes and reads the texels away from the seam at fixed
    // offsets: against the formulas texel by texel, on spiky data, at widths below and around
    // the lanes' eight values, odd sizes, and a map that is 0 everywhere.
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (const Size s : {Size{1, 1}, Size{2, 1}, Size{3, 2}, Size{4, 2}, Size{5, 3}, Size{6, 3}, Size{9, 5},
                         Size{16, 8}, Size{37, 19}, Size{64, 32}, Size{128, 64}}) {
        HdrImage m(s.width, s.height);
        for (float& v : m.data()) v = float(u(rng) < 0.05 ? 1e4 * u(rng) : u(rng) - 0.1);
        const LookupError want = plain_lookup_error(m);
        for (int threads : {1, 2}) {
            const LookupError got = estimate_lookup_error(m, threads);
            const auto near = [](double a, double b) { return std::abs(a - b) <= 1e-12 + 1e-9 * std::abs(b); };
            EXPECT_TRUE(near(got.bilinear_rms, want.bilinear_rms)) << s.width << "x" << s.height << " " << got.bilinear_rms << " " << want.bilinear_rms;
            EXPECT_TRUE(near(got.cubic_rms, want.cubic_rms)) << s.width << "x" << s.height;
            EXPECT_TRUE(near(got.bilinear_worst, want.bilinear_worst)) << s.width << "x" << s.height;
            EXPECT_TRUE(near(got.cubic_worst, want.cubic_worst)) << s.width << "x" << s.height;
            EXPECT_TRUE(near(got.pole_worst, want.pole_worst)) << s.width << "x" << s.height;
            EXPECT_TRUE(near(got.between_worst, want.between_worst)) << s.width << "x" << s.height;
        }
        if (s.width >= 4) {
            EXPECT_GT(want.cubic_worst, 0.0) << "spikes should have differences";
        }
    }
    const HdrImage zero(12, 6);
    const LookupError e = estimate_lookup_error(zero, 2);
    EXPECT_EQ(e.bilinear_rms, 0.0);
    EXPECT_EQ(e.bilinear_worst, 0.0);
    EXPECT_EQ(e.cubic_worst, 0.0);
}

TEST(OutputGrid, TheClampAtThePolesIsPredictedAndFallsWithTheSpacing) {
    // A light brighter to one side of the zenith: a lookup between the pole and the first row's
    // centres holds that row (the conventions' clamp), so it errs by the slope across the pole
    // times the distance, which the second differences do not see. Measured at lookups all
    // over both caps against the field; the estimate bounds it within 2x, and a grid twice as
    // fine halves it (first order), which finer() predicts.
    const auto field = [](const glm::dvec3& d) { return 1.0 + 0.8 * d.x - 0.3 * d.z + 0.2 * d.y; };
    double previous = 0;
    for (int h : {8, 16, 32}) {
        const HdrImage m = sampled(2 * h, h, field);
        const LookupError e = estimate_lookup_error(m, 2);
        const double mean = solid_angle_mean(m);
        double real = 0;
        const double first = kPi / (2 * h);  // the first row's centres from the pole
        for (int a = 0; a < 64; ++a)
            for (int r = 0; r <= 8; ++r)
                for (const double pole : {0.0, kPi}) {
                    const double phi = 2 * kPi * (a + 0.5) / 64, off = first * r / 8.0;
                    const double theta = pole == 0 ? off : kPi - off;
                    const glm::dvec3 d = direction_from_angles(theta, phi);
                    const Rgb got = sample_bilinear(m, d);
                    const double truth = field(d);
                    real = std::max(real, std::abs(got.r - truth) / std::max(std::abs(truth), mean));
                }
        std::printf("[  report  ] %dx%d: lookups in the polar caps worst %.2e, estimate %.2e (between texels %.2e)\n",
                    2 * h, h, real, e.pole_worst, e.between_worst);
        EXPECT_GE(e.bilinear_worst, real) << h;
        EXPECT_GE(e.pole_worst, 0.9 * real) << h;
        EXPECT_LE(e.pole_worst, 2.0 * real) << h;
        EXPECT_GT(e.pole_worst, 4 * e.between_worst) << "the clamp should dominate this field's worst texel";
        if (previous > 0) {
            EXPECT_NEAR(real / previous, 0.5, 0.1) << h << ": the clamp's error is first order in the spacing";
        }
        EXPECT_NEAR(e.finer(2).worst, 0.5 * e.bilinear_worst, 1e-12) << h;
        previous = real;
    }
}

TEST(OutputGrid, LookupsMeasuredInTilesAreTheFinerGridsOwn) {
    // Every tile of a 32x16 base kept, its blocks cut from a field sampled 8x finer: the worst
    // measured between the tiles' texels is the finer grid's own estimate (the lines between
    // tiles, which no block can difference, are left out; this field's worst is elsewhere), and
    // the clamp in the pole tiles is the finer grid's clamp.
    for (const bool linear : {false, true}) {
        // Linear: no curvature but the sphere's, so a first difference taken for a second one (the
        // last tile row holds the last fine row twice) would stand out; it did, 20x at 8x.
        const auto field = [&](const glm::dvec3& d) {
            return 1.0 + 0.8 * d.x - 0.3 * d.z + (linear ? 0.0 : std::sin(5 * d.y));
        };
        const int factor = 8, tile = 4;
        const HdrImage base = sampled(32, 16, field);
        const HdrImage fine = sampled(32 * factor, 16 * factor, field);
        FineTiles f;
        f.factor = factor;
        f.tile = tile;
        f.tiles_x = 32 / tile;
        f.tiles_y = 16 / tile;
        f.slot.resize(std::size_t(f.tiles_x * f.tiles_y));
        const int side = f.side(), t = tile * factor;
        f.blocks = HdrImage(side, side * f.tiles_x * f.tiles_y);
        for (int k = 0; k < f.tiles_x * f.tiles_y; ++k) {
            f.slot[std::size_t(k)] = k;
            const int tx = k % f.tiles_x, ty = k / f.tiles_x;
            for (int v = 0; v < side; ++v)
                for (int u = 0; u < side; ++u)
                    f.blocks.set(u, k * side + v, fine.at((tx * t + u) % fine.width(), std::min(ty * t + v, fine.height() - 1)));
        }
        const double mean = solid_angle_mean(fine);
        const TileLookupWorst got = tile_lookup_worst(base, f, mean);
        const LookupError want = estimate_lookup_error(fine, 2);
        std::printf("[  report  ] in tiles: between %.3e (whole finer grid %.3e), poles %.3e (%.3e)\n", got.between,
                    want.between_worst, got.pole, pole_clamp_worst(fine, mean));
        EXPECT_LE(got.between, want.between_worst * (1 + 1e-9)) << linear;
        EXPECT_GE(got.between, 0.8 * want.between_worst) << linear;
        EXPECT_NEAR(got.pole, pole_clamp_worst(fine, mean), 1e-6);
        EXPECT_NEAR(got.pole, want.pole_worst, 1e-6);
        EXPECT_GT(got.pole, 0.0);
        // No tiles: nothing measured.
        const TileLookupWorst none = tile_lookup_worst(base, FineTiles{}, mean);
        EXPECT_EQ(none.worst(), 0.0);
    }
}

TEST(OutputGrid, AConstantMapHasNoLookupError) {
    const HdrImage m = sampled(32, 16, [](const glm::dvec3&) { return 2.0; });
    const LookupError e = estimate_lookup_error(m, 1);
    EXPECT_EQ(e.bilinear_rms, 0.0);
    EXPECT_EQ(e.cubic_worst, 0.0);
    const HdrImage r = resample_cubic(m, {100, 50}, 2);
    for (float v : r.data()) EXPECT_NEAR(v, v > 1.5f ? 2.0f : (v > 0.9f ? 1.0f : 0.6f), 1e-6);
}

TEST(OutputGrid, FootprintFilterKeepsPowerAndIsTheIdentityAtTheInputSize) {
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0.0, 10.0);
    HdrImage env(64, 32);
    for (float& v : env.data()) v = float(u(rng));
    const HdrImage same = filter_to_footprint(env, {64, 32}, 2);
    EXPECT_EQ(same.data(), env.data());
    const auto power = [](const HdrImage& m) {
        const std::vector<double> solid = row_solid_angles(m.width(), m.height());
        double p = 0;
        for (int j = 0; j < m.height(); ++j)
            for (int i = 0; i < 3 * m.width(); ++i) p += m.row(j)[i] * solid[std::size_t(j)];
        return p;
    };
    for (const Size s : {Size{32, 16}, Size{20, 10}, Size{128, 64}, Size{50, 27}}) {
        const HdrImage f = filter_to_footprint(env, s, 2);
        EXPECT_NEAR(power(f), power(env), 1e-5 * power(env)) << s.width << "x" << s.height;
    }
    // Halving averages each 2x2 block by solid angle.
    const HdrImage half = filter_to_footprint(env, {32, 16}, 1);
    const double a0 = row_solid_angle(0, 64, 32), a1 = row_solid_angle(1, 64, 32);
    const double want = (a0 * (env.at(0, 0).r + env.at(1, 0).r) + a1 * (env.at(0, 1).r + env.at(1, 1).r)) /
                        (2 * (a0 + a1));
    EXPECT_NEAR(half.at(0, 0).r, want, 1e-5 * want);
}

TEST(OutputGrid, BrightLobeAtItsOwnDirectionIsTheNormalisedPeak) {
    const double n = 500;
    BrightTexel t;
    const glm::dvec3 d = texel_direction(10, 7, 64, 32);
    t.x = d.x, t.y = d.y, t.z = d.z;
    t.theta = row_theta(7, 32), t.phi = column_phi(10, 64);
    t.r = 2.0, t.g = 1.0, t.b = 0.5;
    HdrImage lobes(64, 32);
    add_bright_lobes({t}, n, 1.0, LobeOp::AddClamped, lobes, 1);
    EXPECT_NEAR(lobes.at(10, 7).r, (n + 1) / (2 * kPi) * 2.0, 1e-4 * (n + 1));
    // Half a lobe width away it is exp(-1/8) of the peak (cos^n of 0.5/sqrt(n)).
    EXPECT_EQ(lobes.at(40, 7).r, 0.0f);
}

// A bright texel at (theta, phi) holding `value` times `colour` (radiance times solid angle).
BrightTexel bright_texel(double theta, double phi, Rgb colour, double value) {
    BrightTexel t;
    t.theta = theta, t.phi = phi;
    const glm::dvec3 d = direction_from_angles(theta, phi);
    t.x = d.x, t.y = d.y, t.z = d.z;
    t.r = value * colour.r, t.g = value * colour.g, t.b = value * colour.b;
    return t;
}

// A bright texel nearer an output texel's direction than cmax (a texel of a coarse level's
// window) gets its lobe's own weight over the sums' scale, (r.w / cmax)^n, above 1: not clamped
// at 1, which biased such terms low by about n (1 - cmax). Only a power past e^80 is capped.
TEST(OutputGrid, BrightWeightsAboveCmaxAreNotClamped) {
    const Size out{64, 32};
    const int row = 10, column = 20;
    const BrightTexel lamp = bright_texel(row_theta(row, out.height), column_phi(column, out.width), {1, 1, 1}, 1.0);
    for (const double n : {1.0, 10.0, 1000.0, 1e5}) {
        const BrightScatter scatter({lamp}, n, out, 1e-3, 1e-3, 0.99);
        for (const double cmax : {1.0, 0.999, 0.99}) {
            std::vector<double> sums(std::size_t(3 * out.width), 0.0);
            scatter.add_row(row, &cmax, 1, sums.data());
            const double want = std::pow(1.0 / cmax, std::min(n, 80.0 / std::log(1.0 / cmax)));
            EXPECT_NEAR(sums[std::size_t(3 * column)], want, 1e-10 * want) << "n " << n << ", cmax " << cmax;
        }
    }
}

// However many bright texels there are, the terms the scatter drops at an output texel stay below
// its tolerance times the floor together: a compact lamp of 4096 equal texels (a lamp at
// 2048x1024), seen from outside every texel's cut, drops 4096 terms at once. Against the plain
// sum of every term, normalised as the cut is (by the continuous lobe's sum of weights).
TEST(OutputGrid, TheBrightTermsDroppedAtATexelStayWithinTheToleranceTogether) {
    const int in_w = 2048, in_h = 1024;
    std::vector<BrightTexel> bright;
    for (int j = 300; j < 364; ++j)
        for (int i = 900; i < 964; ++i)
            bright.push_back(bright_texel(row_theta(j, in_h), column_phi(i, in_w), {1.0f, 0.8f, 0.6f},
                                          5e2 * row_solid_angle(j, in_w, in_h)));
    const std::vector<double> cmax{1.0};
    const Size out{64, 32};
    const double floor_value = 1.0, tolerance = 1e-3;
    // Red, the largest channel, of the plain sum of `terms` at output texel (i, row).
    const auto plain = [&](const std::vector<BrightTexel>& terms, int i, int row, double n) {
        const glm::dvec3 r = texel_direction(i, row, out.width, out.height);
        double sum = 0;
        for (const BrightTexel& b : terms) {
            const double c = r.x * b.x + r.y * b.y + r.z * b.z;
            if (c > 0) sum += std::pow(std::min(1.0, c), n) * b.r;
        }
        return sum;
    };
    // cmax_floor 0.999 (the cone's) and 1 (SH, resampling): cells of the lamp may be merged
    // first, within half the tolerance of the merged terms and of the floor.
    for (const double cmax_floor : {0.999, 1.0})
    for (const double n : {20.0, 200.0}) {
        const BrightScatter scatter(bright, n, out, floor_value, tolerance, cmax_floor);
        if (n == 20.0) {
            EXPECT_LT(scatter.texels().size(), bright.size()) << "cells merged";
        }
        const double lobe_den = kTwoPi / (n + 1.0);
        double worst = 0, largest = 0, worst_total = 0;
        for (int row = 0; row < out.height; ++row) {
            std::vector<double> got(std::size_t(3 * out.width), 0.0);
            scatter.add_row(row, cmax.data(), 1, got.data());
            for (int i = 0; i < out.width; ++i) {
                const double terms = plain(scatter.texels(), i, row, n);  // after merging: the drops alone
                const double members = plain(bright, i, row, n);
                largest = std::max(largest, members / lobe_den);
                worst = std::max(worst, std::abs(terms - got[3 * std::size_t(i)]) / lobe_den);
                // Against every texel's own term: drops and merges together.
                const double allowed = tolerance * floor_value + 0.5 * tolerance * (terms / lobe_den + floor_value);
                worst_total = std::max(worst_total, std::abs(members - got[3 * std::size_t(i)]) / lobe_den / allowed);
            }
        }
        EXPECT_GT(largest, 10 * floor_value) << "n " << n;  // the lamp is bright where it is seen
        EXPECT_LE(worst, tolerance * floor_value) << "n " << n;
        EXPECT_LE(worst_total, 1.0) << "n " << n;
        // The cut is where the budget allows, not far past it (which would pass the bound too).
        EXPECT_GT(worst, 0.01 * tolerance * floor_value) << "n " << n;
        std::printf("cmax floor %g, n %g: dropped at most %.3g of the budget, %.3g of drops and merges (%zu terms "
                    "for %zu texels)\n",
                    cmax_floor, n, worst / (tolerance * floor_value), worst_total, scatter.texels().size(),
                    bright.size());
    }
}

// Cells of bright texels merged into one term each (merge_bright_cells) differ from the sum of
// their members by at most `relative` times the merged terms plus `absolute`, at any direction:
// checked against the plain sums at random directions and along the lamps, for a 64x64 lamp of
// texels at 8192x4096's spacing whose colour changes from texel to texel, a strip over the
// seam and a cap round the north pole, from a lobe of n = 2 to n = 2000. The colours change
// by up to 50x between texels: with the bound's first-order (colour) term left out, n = 20 and
// 200 err 1.08x and 1.23x their allowance here; with it, at most 0.34x.
TEST(OutputGrid, MergedBrightCellsStayWithinTheirBound) {
    const int in_w = 8192, in_h = 4096;
    std::vector<BrightTexel> bright;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> tint(0.02, 1.0), level(0.2, 1.0);
    const auto add = [&](int i, int j, double value, bool blue = true) {
        const float r = float(tint(rng)), g = float(tint(rng)), bl = float(tint(rng));
        bright.push_back(bright_texel(row_theta(j, in_h), column_phi(i, in_w), {r, g, blue ? bl : 0.0f},
                                      value * level(rng) * row_solid_angle(j, in_w, in_h)));
    };
    for (int j = 1500; j < 1564; ++j)
        for (int i = 3000; i < 3064; ++i) add(i, j, 1e4);
    for (int j = 2000; j < 2004; ++j)
        for (int i = -40; i < 40; ++i) add((i + in_w) % in_w, j, 5e4, false);  // no blue at all
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < in_w; i += 16) add(i, j, 2e4);
    std::vector<glm::dvec3> at;
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    while (at.size() < 800) {
        const glm::dvec3 v(uniform(rng), uniform(rng), uniform(rng));
        if (glm::length(v) > 0.1 && glm::length(v) <= 1) at.push_back(glm::normalize(v));
    }
    for (int k = 0; k < 400; ++k) {  // across the lamp and the strip, and near the pole
        at.push_back(direction_from_angles(row_theta(1532, in_h) + (k - 200) * 1e-3, column_phi(3032, in_w)));
        at.push_back(direction_from_angles(row_theta(2002, in_h), column_phi(0, in_w) + (k - 200) * 2e-3));
        at.push_back(direction_from_angles(k * 2e-3, 0.7));
    }
    const double relative = 1e-3;
    double peaks = 0;
    for (const BrightTexel& t : bright) peaks += std::max({t.r, t.g, t.b});
    for (const double n : {2.0, 5.0, 20.0, 200.0, 2000.0}) {
        // The allowance a scatter gives: its tolerance's half of a floor of 1e-3 of the peaks'
        // mean radiance, in weight units.
        const double absolute = relative * 1e-3 * peaks / (4 * kPi) * kTwoPi / (n + 1);
        const std::vector<BrightTexel> merged = merge_bright_cells(bright, n, relative, absolute);
        const auto sum = [&](const std::vector<BrightTexel>& terms, const glm::dvec3& r, double out[3]) {
            out[0] = out[1] = out[2] = 0;
            for (const BrightTexel& b : terms) {
                const double c = r.x * b.x + r.y * b.y + r.z * b.z;
                if (c <= 0) continue;
                const double w = std::pow(std::min(1.0, c), n);
                out[0] += w * b.r, out[1] += w * b.g, out[2] += w * b.b;
            }
        };
        double worst = 0;  // of the error over its allowance
        for (const glm::dvec3& r : at) {
            double members[3], cells[3];
            sum(bright, r, members);
            sum(merged, r, cells);
            for (int ch = 0; ch < 3; ++ch)
                worst = std::max(worst, std::abs(members[ch] - cells[ch]) / (relative * cells[ch] + absolute));
        }
        EXPECT_LE(worst, 1.0) << "n " << n;
        // A sanity check, not implied by the bound: each merged term holds its members' energy
        // times mu^n, a little less.
        double before = 0, after = 0;
        for (const BrightTexel& t : bright) before += t.r;
        for (const BrightTexel& t : merged) after += t.r;
        EXPECT_LE(after, before * (1 + 1e-12)) << "n " << n;
        EXPECT_GT(after, before * (1 - relative)) << "n " << n;
        // n = 2 cannot merge within so small an allowance: its cells' error near the horizon,
        // about E s^2 sin^2(alpha), does not fall with the merged term, E cos^2(alpha).
        if (n >= 5 && n <= 20) {
            EXPECT_LT(merged.size(), bright.size() / 5) << "n " << n;
            // Some cells are merged per channel (a term of one channel; every texel has two or
            // three), and none has a blue term made of the strip's blue-less texels alone.
            long long one_channel = 0;
            for (const BrightTexel& t : merged) one_channel += (t.r > 0) + (t.g > 0) + (t.b > 0) == 1;
            EXPECT_GT(one_channel, 0) << "n " << n;
        }
        std::printf("n %g: %zu terms for %zu texels, error at most %.3g of the allowance\n", n, merged.size(),
                    bright.size(), worst);
    }
    // Fewer than 256 texels, or a lobe below n = 2: as they are.
    const std::vector<BrightTexel> few(bright.begin(), bright.begin() + 255);
    EXPECT_EQ(merge_bright_cells(few, 20, relative, 1.0).size(), few.size());
    EXPECT_EQ(merge_bright_cells(bright, 1.5, relative, 1.0).size(), bright.size());
}

// Bright texels of one polar angle at one phase between output columns share their staged
// weights (BrightScatter's groups): the sums must be those of each texel on its own, across
// the seam, at the pole, with one or several column classes, whole rows or asked columns only.
TEST(OutputGrid, GroupedBrightTexelsSumAsEachOnItsOwn) {
    const int in_w = 32, in_h = 16;
    std::vector<BrightTexel> bright;
    const auto add = [&](double i, int j, double value) {
        bright.push_back(bright_texel(row_theta(j, in_h), -kPi + (i + 0.5) * kTwoPi / in_w, {1.0f, 0.5f, 0.25f}, value));
    };
    double value = 3e4;
    for (int i : {0, 1, 2, 3, 7, 28, 29, 30, 31}) add(i, 5, value *= 0.8);   // a strip over the seam
    for (int i : {10, 11, 12, 13}) add(i, 6, value *= 1.3);                  // the next row
    for (int i : {0, 9, 17}) add(i, 0, 2e3);                                 // the polar row
    add(3.37, 5, 5e3);                                                       // same row, another phase
    const std::vector<double> one_class{1.0}, four_classes{1.0, 0.9993, 0.9998, 0.9991};
    const LobeSummer::ColumnRuns columns{{0, 5}, {40, 60}, {90, 96}};
    // 4x the input's columns: the texels of a row are 4 columns apart, as are the classes;
    // 3x: a shift of 3 columns moves a texel into another class.
    for (const Size out : {Size{128, 64}, Size{96, 48}})
    // (Not n = 0: its weight jumps from 1 to 0 at the horizon, where a texel centre can lie
    // exactly and rounding picks either side, grouped or not.)
    for (const double n : {1.0, 20.0, 500.0, 20480.0, 1e6}) {
        const BrightScatter all(bright, n, out, 1.0, 1e-6);
        // Each texel alone with its share of the budget (its peak over the peaks' sum, times the
        // set's count: a budget ramps with the count below 1000 texels): the same cut as in the
        // whole set.
        std::vector<std::vector<BrightTexel>> singles;
        std::vector<double> share;
        double peaks = 0;
        for (const BrightTexel& t : bright) peaks += std::max({t.r, t.g, t.b});
        for (const BrightTexel& t : bright) {
            singles.push_back({t});
            share.push_back(std::max({t.r, t.g, t.b}) / peaks);
        }
        for (const std::vector<double>* cmax : {&one_class, &four_classes}) {
            const int classes = int(cmax->size());
            for (const LobeSummer::ColumnRuns* runs : {static_cast<const LobeSummer::ColumnRuns*>(nullptr), &columns}) {
                double largest = 0, worst = 0;
                for (int row = 0; row < out.height; ++row) {
                    std::vector<double> grouped(std::size_t(3 * out.width), 0.0), alone(grouped.size(), 0.0);
                    all.add_row(row, cmax->data(), classes, grouped.data(), runs);
                    for (std::size_t k = 0; k < singles.size(); ++k) {
                        const auto& single = singles[k];
                        const BrightScatter one(single, n, out, 1.0, 1e-6 * share[k] * double(bright.size()));
                        one.add_row(row, cmax->data(), classes, alone.data(), runs);
                    }
                    for (std::size_t i = 0; i < grouped.size(); ++i) {
                        largest = std::max(largest, alone[i]);
                        worst = std::max(worst, std::abs(grouped[i] - alone[i]) / std::max(1e-300, alone[i]));
                        if (alone[i] == 0) {
                            EXPECT_EQ(grouped[i], 0.0) << "n " << n << " row " << row << " i " << i;
                        }
                    }
                }
                EXPECT_GT(largest, 0.0) << "n " << n;
                EXPECT_LT(worst, 1e-9) << out.width << " columns, n " << n << ", " << classes << " classes"
                                       << (runs ? ", asked columns" : "");
            }
        }
    }
}

// For n = 1 a cluster of bright texels wholly in front of a texel adds one dot product instead
// of its members' terms (BrightScatter's clusters), for n = 0 its energy, and for other n below 2
// a Taylor series about its centre (within 1e-5; without its third-order term 1.9x that): against the plain
// sum of every term, with clusters at the seam, around the pole and in the open, cmax below 1
// (weights c/cmax above 1 near the texels, unclamped), one and four column classes and asked
// columns.
TEST(OutputGrid, BrightClustersForIrradianceMatchThePlainSum) {
    const int in_w = 512, in_h = 256;
    std::vector<BrightTexel> bright;
    const auto add = [&](int i, int j, double value) {
        bright.push_back(bright_texel(row_theta(j, in_h), column_phi(i, in_w), {1.0f, 0.7f, 0.2f}, value));
    };
    for (int j = 90; j < 96; ++j)
        for (int i = 300; i < 310; ++i) add(i, j, 50.0 + i - j);           // a lamp in the open
    for (int j = 40; j < 44; ++j)
        for (int i : {508, 509, 510, 511, 0, 1, 2}) add(i, j, 80.0 + j);   // a window over the seam
    for (int i = 0; i < in_w; i += 37) add(i, 1, 30.0);                    // around the pole
    add(100, 200, 400.0);                                                  // a lone sun below
    // Off the grid, lopsided members within a cluster's cell: odd moments about its centre, which
    // a symmetric cell's cancel (the third-order term of the Taylor series for n < 2).
    // Bright enough that the term stands out of the allowance for dropped terms.
    for (const auto& [dt, dp, value] : {std::tuple{0.0, 0.0, 4e6}, std::tuple{0.011, 0.0, 3e5},
                                        std::tuple{0.011, 0.006, 9e6}, std::tuple{0.003, 0.013, 1e6}})
        bright.push_back(bright_texel(1.905 + dt, -1.19 + dp, {0.9f, 1.0f, 0.6f}, value));  // one cell
    const std::vector<double> one_class{1.0}, four_classes{0.9993, 0.9981, 0.9998, 0.9989};
    for (const double n : {1.0, 0.0, 0.5, 1.5, 0.1})
    for (const Size out : {Size{128, 64}, Size{96, 48}, Size{512, 256}}) {
        const LobeSummer::ColumnRuns columns{{0, 5}, {40, 60}, {out.width - 6, out.width}};
        const BrightScatter scatter(bright, n, out, 1.0, 1e-6);
        for (const std::vector<double>* cmax : {&one_class, &four_classes}) {
            const int classes = int(cmax->size());
            for (const LobeSummer::ColumnRuns* runs : {static_cast<const LobeSummer::ColumnRuns*>(nullptr), &columns}) {
                double worst = 0, largest = 0;
                for (int row = 0; row < out.height; ++row) {
                    std::vector<double> got(std::size_t(3 * out.width), 0.0);
                    scatter.add_row(row, cmax->data(), classes, got.data(), runs);
                    for (int i = 0; i < out.width; ++i) {
                        const bool asked = !runs || std::any_of(runs->begin(), runs->end(), [&](const auto& r) {
                            return i >= r.first && i < r.second;
                        });
                        const glm::dvec3 d = texel_direction(i, row, out.width, out.height);
                        const double cm = (*cmax)[std::size_t(i % classes)];
                        double want[3] = {0, 0, 0}, edge[3] = {0, 0, 0};
                        for (const BrightTexel& b : bright) {
                            const double c = glm::dot(d, glm::dvec3(b.x, b.y, b.z));
                            const double w = c > 0 ? (n == 0 ? 1.0 : std::pow(c / cm, n)) : 0.0;  // unclamped, as the cone's
                            want[0] += w * b.r, want[1] += w * b.g, want[2] += w * b.b;
                            // n = 0 steps at the horizon: a texel within rounding of it (these
                            // grids put some exactly 90 degrees apart) may be on either side. So
                            // for n < 1 a weight (c / cm)^n rises steeply from it: a cosine of 1e-17
                            // against -1e-17 weighs 0.02 at n = 0.1.
                            if (n < 1 && std::abs(c) < 1e-12) {
                                const double e = n == 0 ? 1.0 : std::pow(1e-12 / cm, n);
                                edge[0] += e * b.r, edge[1] += e * b.g, edge[2] += e * b.b;
                            }
                        }
                        for (int ch = 0; ch < 3; ++ch) {
                            const double g = got[std::size_t(3 * i + ch)];
                            if (!asked) {
                                EXPECT_EQ(g, 0.0) << "a column not asked for";
                                continue;
                            }
                            largest = std::max(largest, want[ch]);
                            // Terms below 1e-6 of the floor (1 here) times the lobe's sum may be
                            // dropped: at most one such term per bright texel.
                            // Other n: the clusters' Taylor series within 1e-5 of their sums.
                            const double series = n == 0 || n == 1 ? 1e-9 : 1e-5;
                            worst = std::max(worst, std::abs(g - want[ch]) /
                                                        (series * want[ch] + 1e-6 * kPi * double(bright.size()) + edge[ch]));
                        }
                    }
                }
                EXPECT_GT(largest, 100.0);
                EXPECT_LT(worst, 1.0) << "n " << n << ", " << out.width << " columns, " << classes << " classes"
                                      << (runs ? ", asked columns" : "");
            }
        }
    }
}

// A map with one bright texel on a smooth field: the sharpest content a lobe gets.
HdrImage field_with_sun(int w, int h) {
    HdrImage m = sampled(w, h, smooth_field);
    m.set(w / 3, h / 3, {4000.f, 3000.f, 2000.f});
    return m;
}

TEST(OutputGrid, DeliveredMapsAreWithinTheirPredictionOffGrid) {
    // Without a fixed size, each map's bilinear lookups at random directions are within what
    // its plan predicts (plus the judge's statistical error), and its size says why.
    const HdrImage env = field_with_sun(256, 128);
    std::vector<MapRequest> maps{MapRequest::make_irradiance()};
    for (double n : {20.0, 300.0, 2000.0}) maps.push_back(MapRequest::make_phong(n, std::to_string(int(n))));
    Options o;
    o.threads = 2;
    for (const MapResult& r : convolve(env, maps, o)) {
        const OffGridError e = measure_offgrid_error(env, r.image, r.request.shininess, 1024, 7, 2, r.plan.lookup);
        std::printf("[  report  ] %-11s %dx%d predicted %.4f off-grid %.4f +- %.4f worst %.3f (%s)\n",
                    r.request.label.c_str(), r.image.width(), r.image.height(), r.plan.predicted_error,
                    e.weighted_relative_rms, e.rms_standard_error, e.worst_texel, r.plan.size_reason.c_str());
        EXPECT_LE(r.plan.predicted_error, o.tolerance) << r.request.label;
        EXPECT_LE(e.weighted_relative_rms, o.tolerance + 3 * e.rms_standard_error) << r.request.label;
        EXPECT_FALSE(r.plan.size_reason.empty());
    }
}

TEST(OutputGrid, OddAndNonSquareInputsGetGridsThatKeepTheirPrediction) {
    // Input sizes off the power-of-two ladder, odd widths (no half-turn column across the pole)
    // and a 4:1 aspect: every map finite, twice as wide as high, and, where its lookups are
    // counted, within its prediction off-grid.
    for (const Size in : {Size{90, 45}, Size{100, 50}, Size{128, 32}, Size{33, 17}}) {
        const HdrImage env = field_with_sun(in.width, in.height);
        std::vector<MapRequest> maps{MapRequest::make_irradiance(), MapRequest::make_mirror()};
        for (double n : {10.0, 200.0, 3000.0}) maps.push_back(MapRequest::make_phong(n, std::to_string(int(n))));
        Options o;
        o.threads = 2;
        for (const MapResult& r : convolve(env, maps, o)) {
            const std::string what = to_string(in) + " " + r.request.label;
            for (float v : r.image.data()) ASSERT_TRUE(std::isfinite(v) && v >= 0) << what;
            EXPECT_EQ(r.image.width(), r.plan.output_size.width) << what;
            EXPECT_FALSE(r.plan.size_reason.empty()) << what;
            if (r.request.mirror || r.plan.size_reason.find("narrower than half") != std::string::npos) continue;
            const OffGridError e = measure_offgrid_error(env, r.image, r.request.shininess, 512, 3, 2, r.plan.lookup);
            std::printf("[  report  ] %-14s %dx%d predicted %.4f off-grid %.4f +- %.4f\n", what.c_str(),
                        r.image.width(), r.image.height(), r.plan.predicted_error, e.weighted_relative_rms,
                        e.rms_standard_error);
            EXPECT_LE(e.weighted_relative_rms, std::max(o.tolerance, 1.25 * r.plan.predicted_error) +
                                                   3 * e.rms_standard_error)
                << what;
        }
    }
}

// Inputs whose height halves to an odd number far above what a lobe needs (3000x1500: 1500 ->
// 750 -> 375) sum on a grid that divides the input, so that the pyramid's columns fall in few
// phase classes of the output's: a grid of just the rows needed (212x106 for n = 640) shares no
// factor with the levels, and its sums took 3.3 s against 0.5 s at 250x125.
TEST(OutputGrid, GridsBelowAnOddLadderStepDivideTheInput) {
    const PlannerModel model;
    for (const Size in : {Size{3000, 1500}, Size{2000, 1000}, Size{6000, 3000}, Size{8000, 4000}})
        for (const double n : {80.0, 160.0, 320.0, 640.0, 1280.0}) {
            const Size grid = sum_grid_size(n, in, model);
            const std::string what = to_string(in) + " n " + std::to_string(int(n)) + ": " + to_string(grid);
            EXPECT_EQ(grid.width, 2 * grid.height) << what;
            EXPECT_LE(kPi / grid.height, model.sum_grid_spacing * lobe_width(n) * 1.0001) << what;
            EXPECT_EQ(in.height % grid.height, 0) << what;
            EXPECT_EQ(in.width % grid.width, 0) << what;
        }
}

// An input whose ladder stops at an odd height sums a sharp lobe on a coarser grid than a
// power-of-two input does (3000x1500's n = 20480 on 1500x750, 4096x2048's on 2048x1024), and its
// tiles 2x finer were all that 2048 rows allowed: sunset at 3000x1500 and 6000x3000 was refused
// at 1.32 % predicted. Tiles may go to kMaxTiledHeight rows while the lookups keep a map over
// the tolerance; the map is then within it, off-grid too.
TEST(OutputGrid, TilesGoFinerThanAWholeGridMayWhereTheLadderStopsShort) {
    HdrImage env = sampled(3000, 1500, smooth_field);
    for (int j = 0; j < 3; ++j)  // a sun of 3x3 texels, 0.36 degrees
        for (int i = 0; i < 3; ++i) env.set(1000 + i, 500 + j, {6000.f, 4500.f, 3000.f});
    Options o;
    o.threads = 2;
    o.fine_tiles = true;  // glint convolve's default
    const auto r = convolve(env, {MapRequest::make_phong(20480, "20480")}, o);
    const MapPlan& p = r[0].plan;
    std::printf("[  report  ] 3000x1500 n 20480: predicted %.4f, sum %dx%d, tiles %dx (%s)\n", p.predicted_error,
                p.sum_size.width, p.sum_size.height, r[0].fine.empty() ? 1 : r[0].fine.factor, p.size_reason.c_str());
    EXPECT_EQ(p.sum_size.height, 750);
    ASSERT_FALSE(r[0].fine.empty()) << p.size_reason;
    EXPECT_GT(p.sum_size.height * r[0].fine.factor, kMaxOutputHeight);
    EXPECT_LE(p.predicted_error, o.tolerance) << p.size_reason;
    const OffGridError e = measure_offgrid_error(env, r[0].image, 20480, 256, 9, 2, p.lookup, &r[0].fine);
    std::printf("[  report  ] off-grid %.4f +- %.4f, worst %.3f\n", e.weighted_relative_rms, e.rms_standard_error,
                e.worst_texel);
    EXPECT_LE(e.weighted_relative_rms, o.tolerance + 3 * e.rms_standard_error);
}

TEST(OutputGrid, AHandedOverMapGivesTheSameMaps) {
    // convolve(HdrImage&&) splits the map in place and frees the remainder's level 0 when no
    // plan reads them; the maps must be bit-identical to those of the copying call, with and
    // without plans that read level 0 or the whole map (the mirror).
    const HdrImage env = field_with_sun(256, 128);
    const std::vector<std::vector<MapRequest>> sets{
        {MapRequest::make_irradiance(), MapRequest::make_phong(20, "20")},
        {MapRequest::make_irradiance(), MapRequest::make_phong(3000, "3000")},
        {MapRequest::make_phong(40, "40"), MapRequest::make_mirror()}};
    Options o;
    o.threads = 2;
    for (const auto& maps : sets) {
        const auto copied = convolve(env, maps, o);
        HdrImage handed = env;
        const auto moved = convolve(std::move(handed), maps, o);
        ASSERT_EQ(copied.size(), moved.size());
        for (std::size_t k = 0; k < copied.size(); ++k)
            EXPECT_EQ(copied[k].image.data(), moved[k].image.data()) << copied[k].request.label;
    }
}

// A smooth field with a narrow, bright bump at `centre`: too sharp for 4-point resampling
// from a coarse grid near the bump, easy elsewhere.
double field_with_bump(const glm::dvec3& d, const glm::dvec3& centre) {
    return smooth_field(d) + 200.0 * std::exp(600.0 * (glm::dot(d, centre) - 1.0));
}

TEST(OutputGrid, PatchesMarkTheTexelsNearASharpBumpAndLeaveTheRestWithinBudget) {
    // Resampled from 64x32 to 256x128, the fine texels outside the selection are within the
    // worst budget of the field sampled there (the estimate predicts them), the selection is
    // a small part of the fine grid, and it holds the bump.
    const glm::dvec3 c = glm::normalize(glm::dvec3(0.4, 0.3, 0.8));
    const auto f = [&](const glm::dvec3& d) { return field_with_bump(d, c); };
    const HdrImage coarse = sampled(64, 32, f);
    const HdrImage fine = sampled(256, 128, f);
    const double rms_budget = 0.0025, worst_budget = 0.02;
    const LookupError whole = estimate_lookup_error(coarse, 2);
    ASSERT_GT(whole.cubic_worst, worst_budget) << "the test needs a field that 4-point resampling misses";
    const ResamplePatches patches = plan_resample_patches(coarse, rms_budget, worst_budget, 2);
    EXPECT_GT(patches.count, 0);
    EXPECT_LE(patches.remaining_rms, rms_budget);
    EXPECT_LE(patches.remaining_worst, worst_budget);
    const TexelSelection selection = fine_texels_near(patches.texels, {64, 32}, {256, 128}, 2);
    EXPECT_LT(selection.texels, 256 * 128 / 10);
    std::vector<char> selected(std::size_t(256 * 128), 0);
    for (std::size_t k = 0; k < selection.rows.size(); ++k)
        for (const auto& [first, last] : selection.runs[k])
            for (int i = first; i < last; ++i) selected[std::size_t(selection.rows[k]) * 256 + std::size_t(i)] = 1;
    const HdrImage r = resample_cubic(coarse, {256, 128}, 2);
    const double mean = solid_angle_mean(fine);
    double worst_outside = 0;
    bool bump_selected = false;
    for (int j = 0; j < 128; ++j)
        for (int i = 0; i < 256; ++i) {
            const bool sel = selected[std::size_t(j) * 256 + std::size_t(i)] != 0;
            if (glm::dot(texel_direction(i, j, 256, 128), c) > 0.9995) bump_selected = bump_selected || sel;
            if (sel) continue;
            for (int ch = 0; ch < 3; ++ch) {
                const double want = fine.row(j)[3 * i + ch];
                worst_outside =
                    std::max(worst_outside, std::abs(r.row(j)[3 * i + ch] - want) / std::max(std::abs(want), mean));
            }
        }
    std::printf("[  report  ] %lld coarse texels marked, %lld fine texels selected; worst outside %.4f "
                "(budget %.3f, whole map predicted %.3f)\n",
                patches.count, selection.texels, worst_outside, worst_budget, whole.cubic_worst);
    EXPECT_TRUE(bump_selected);
    EXPECT_LE(worst_outside, worst_budget);
}

TEST(OutputGrid, FineTexelsNearAMarkedTexelFollowTheSeamAndThePole) {
    // Coarse texel (0, 0) of 16x8 marked: the fine 64x32 texels between it and its neighbours
    // are selected, on both sides of the seam, and across the pole half a turn round; a texel
    // far away is not.
    std::vector<char> marked(16 * 8, 0);
    marked[0] = 1;
    const TexelSelection s = fine_texels_near(marked, {16, 8}, {64, 32}, 2);
    const auto has = [&](int i, int j) {
        for (std::size_t k = 0; k < s.rows.size(); ++k)
            if (s.rows[k] == j)
                for (const auto& [first, last] : s.runs[k])
                    if (i >= first && i < last) return true;
        return false;
    };
    EXPECT_TRUE(has(0, 0));
    EXPECT_TRUE(has(63, 0));   // across the seam
    EXPECT_TRUE(has(3, 3));    // towards (1, 1) of the coarse grid
    EXPECT_TRUE(has(32, 0));   // across the pole: coarse row -1 is row 0 half a turn round
    EXPECT_FALSE(has(16, 16));
    EXPECT_FALSE(has(32, 8));
    long long counted = 0;
    for (const auto& runs : s.runs)
        for (const auto& [first, last] : runs) counted += last - first;
    EXPECT_EQ(counted, s.texels);
}

TEST(OutputGrid, FineTexelsNearMatchTheCellsTexelByTexel) {
    // Random marks on coarse grids, fine grids 1-4.5x finer (and one coarser): a fine texel is
    // selected exactly when a corner of the coarse cell holding its centre is marked, the
    // corners continued across the seam and the poles.
    std::mt19937 rng(9);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (const auto& [coarse, fine] : std::vector<std::pair<Size, Size>>{
             {{16, 8}, {64, 32}}, {{16, 8}, {16, 8}}, {{10, 5}, {45, 23}}, {{32, 16}, {24, 12}}, {{7, 4}, {28, 16}}}) {
        for (double density : {0.02, 0.3}) {
            std::vector<char> marked(std::size_t(coarse.width * coarse.height));
            for (char& m : marked) m = u(rng) < density ? 1 : 0;
            const TexelSelection s = fine_texels_near(marked, coarse, fine, 2);
            std::vector<char> got(std::size_t(fine.width * fine.height), 0);
            for (std::size_t k = 0; k < s.rows.size(); ++k)
                for (const auto& [first, last] : s.runs[k])
                    for (int i = first; i < last; ++i) got[std::size_t(s.rows[k] * fine.width + i)] = 1;
            const auto is_marked = [&](int i, int j) {
                if (j < 0 || j >= coarse.height) {
                    j = j < 0 ? std::min(-1 - j, coarse.height - 1) : std::max(2 * coarse.height - 1 - j, 0);
                    i += coarse.width / 2;
                }
                i = ((i % coarse.width) + coarse.width) % coarse.width;
                return marked[std::size_t(j * coarse.width + i)] != 0;
            };
            long long count = 0;
            for (int j = 0; j < fine.height; ++j)
                for (int i = 0; i < fine.width; ++i) {
                    const int bi = int(std::floor((i + 0.5) * coarse.width / fine.width - 0.5));
                    const int bj = int(std::floor((j + 0.5) * coarse.height / fine.height - 0.5));
                    const bool want = is_marked(bi, bj) || is_marked(bi + 1, bj) || is_marked(bi, bj + 1) ||
                                      is_marked(bi + 1, bj + 1);
                    count += want ? 1 : 0;
                    ASSERT_EQ(got[std::size_t(j * fine.width + i)] != 0, want)
                        << coarse.width << "x" << coarse.height << " -> " << fine.width << "x" << fine.height
                        << " texel " << i << "," << j;
                }
            EXPECT_EQ(s.texels, count);
        }
    }
}

TEST(OutputGrid, ConeOnSelectedTexelsMatchesTheWholeGridThere) {
    // cone_convolve restricted to column runs gives, at those texels, the whole grid's values
    // within the cone's bound of the exact sum (the cut-off's widening may differ: its floor is
    // the smallest value over the texels computed), and 0 elsewhere.
    const HdrImage env = field_with_sun(128, 64);
    const PreparedLevel level(env, 2);
    ConeSettings settings;
    const std::vector<BrightTexel> none;
    const Size out{256, 128};
    const HdrImage whole = cone_convolve(level, none, 800.0, out, settings, 2, nullptr, nullptr);
    const std::vector<int> rows{0, 5, 40, 127};
    const std::vector<LobeSummer::ColumnRuns> runs{{{0, 3}, {250, 256}}, {{17, 18}}, {{100, 140}}, {{128, 130}}};
    const HdrImage part = cone_convolve(level, none, 800.0, out, settings, 2, nullptr, nullptr, rows, nullptr, &runs);
    for (std::size_t k = 0; k < rows.size(); ++k) {
        std::vector<char> in(256, 0);
        for (const auto& [first, last] : runs[k])
            for (int i = first; i < last; ++i) in[std::size_t(i)] = 1;
        for (int i = 0; i < 256; ++i)
            for (int c = 0; c < 3; ++c) {
                const float got = part.row(rows[k])[3 * i + c];
                if (in[std::size_t(i)]) {
                    const double want = exact_at_double(env, 800.0, texel_direction(i, rows[k], 256, 128))[c];
                    EXPECT_NEAR(got, want, settings.texel_tolerance * want) << rows[k] << " " << i;
                    EXPECT_NEAR(got, whole.row(rows[k])[3 * i + c], 1e-3 * want) << rows[k] << " " << i;
                } else
                    EXPECT_EQ(got, 0.0f);
            }
    }
}

TEST(OutputGrid, PatchedMapsAreWithinTheToleranceOffGrid) {
    // Small very bright lights (a few texels, 1e3-1e5 times the field) on a textured field:
    // sharp lobes are resampled with the texels near the lights summed exactly. Some map
    // takes that route, and every map's lookups at random directions are within tolerance.
    HdrImage env = sampled(256, 128, [](const glm::dvec3& d) {
        return smooth_field(d) * (1.0 + 0.5 * std::sin(9.0 * d.x) * std::cos(7.0 * d.y + 2.0 * d.z));
    });
    std::mt19937 rng(11);
    std::uniform_int_distribution<int> col(0, 255), row(0, 127);
    for (int k = 0; k < 6; ++k) {
        const int i = col(rng), j = row(rng);
        const float v = float(std::pow(10.0, 3 + k % 3));
        env.set(i, j, {v, 0.8f * v, 0.6f * v});
        env.set((i + 1) % 256, j, {0.5f * v, 0.4f * v, 0.3f * v});
    }
    std::vector<MapRequest> maps;
    for (double n : {200.0, 800.0, 1600.0, 3000.0}) maps.push_back(MapRequest::make_phong(n, std::to_string(int(n))));
    Options o;
    o.threads = 2;
    long long patched = 0;
    for (const MapResult& r : convolve(env, maps, o)) {
        patched += r.patched_texels;
        const OffGridError e = measure_offgrid_error(env, r.image, r.request.shininess, 2048, 5, 2, r.plan.lookup);
        std::printf("[  report  ] %-5s %dx%d patched %lld predicted %.4f off-grid %.4f +- %.4f (%s)\n",
                    r.request.label.c_str(), r.image.width(), r.image.height(), r.patched_texels,
                    r.plan.predicted_error, e.weighted_relative_rms, e.rms_standard_error, r.plan.size_reason.c_str());
        EXPECT_LE(r.plan.predicted_error, o.tolerance) << r.request.label;
        EXPECT_LE(e.weighted_relative_rms, o.tolerance + 3 * e.rms_standard_error) << r.request.label;
    }
    EXPECT_GT(patched, 0) << "no map took the patched route; the test does not test it";
}

TEST(OutputGrid, MapsInASetMatchTheSameMapsAlone) {
    // A level of the remainder is freed when the last map reading it is done: maps at shared
    // and separate levels, run concurrently, give what each gives alone, to within the SH
    // projection's order, which a set may raise (phong_20: 1.4e-4); a level freed too early
    // throws (the pyramid refuses a released level) or reads freed memory.
    const HdrImage env = field_with_sun(256, 128);
    std::vector<MapRequest> maps{MapRequest::make_irradiance()};
    for (double n : {20.0, 300.0, 320.0, 2000.0, 3000.0}) maps.push_back(MapRequest::make_phong(n, std::to_string(int(n))));
    maps.push_back(MapRequest::make_mirror());
    Options o;
    o.threads = 2;
    const std::vector<MapResult> set = convolve(env, maps, o);
    for (std::size_t k = 0; k < maps.size(); ++k) {
        const MapResult alone = convolve(env, {maps[k]}, o).front();
        ASSERT_EQ(alone.image.width(), set[k].image.width()) << maps[k].label;
        EXPECT_LT(compare_maps(set[k].image, alone.image).weighted_relative_rms, 1e-3) << maps[k].label;
    }
}

TEST(OutputGrid, MirrorIsTheEnvironmentFilteredToTheOutput) {
    const HdrImage env = field_with_sun(64, 32);
    Options o;
    const auto at_input = convolve(env, {MapRequest::make_mirror()}, o);
    EXPECT_EQ(at_input[0].plan.method, Method::Mirror);
    EXPECT_EQ(at_input[0].image.data(), env.data());
    EXPECT_EQ(at_input[0].plan.predicted_error, 0.0);
    o.size = Size{32, 16};
    for (Method m : {Method::Auto, Method::Exact, Method::Cone, Method::Sh}) {
        o.method = m;
        const auto half = convolve(env, {MapRequest::make_mirror()}, o);
        EXPECT_EQ(half[0].image.data(), filter_to_footprint(env, {32, 16}, 1).data()) << to_string(m);
    }
}

TEST(OutputGrid, SharpestLobesStayFiniteAndMatchExactAtOddSizes) {
    // n = 1e6 and 1e7 on a map whose texels are far wider than the lobe, at output sizes whose
    // centres fall between the input's: the nearest texels, never 0/0, within tau of exact.
    const HdrImage env = field_with_sun(64, 32);
    for (double n : {1e6, 1e7})
        for (const Size s : {Size{50, 25}, Size{64, 32}, Size{13, 7}}) {
            Options o;
            o.size = s;
            const MapRequest req = MapRequest::make_phong(n, "big");
            const auto a = convolve(env, {req}, o);
            o.method = Method::Exact;
            const auto x = convolve(env, {req}, o);
            for (float v : a[0].image.data()) ASSERT_TRUE(std::isfinite(v));
            const MapError err = compare_maps(a[0].image, x[0].image);
            EXPECT_LE(err.weighted_relative_rms, 0.01) << n << " " << s.width << "x" << s.height;
            EXPECT_LE(err.worst_texel, 0.05) << n << " " << s.width << "x" << s.height;
        }
}

// A lobe narrower than half the input's texel spacing (n > (2H/pi)^2 = 415 on 64x32): without a
// fixed size the map is the input's texels, read through the lobe, and that read is the exact
// sum anywhere; bilinear lookups of any grid would follow the step between texels poorly.
TEST(OutputGrid, LobesNarrowerThanHalfATexelAreTheInputReadThroughTheLobe) {
    const HdrImage env = field_with_sun(64, 32);
    for (const double n : {500.0, 1e6})
        for (Method m : {Method::Auto, Method::Cone, Method::Exact}) {
            Options o;
            o.method = m;
            const auto r = convolve(env, {MapRequest::make_phong(n, "sharp")}, o);
            const std::string where = "n " + std::to_string(n) + " " + to_string(m);
            EXPECT_EQ(r[0].plan.lookup, MapLookup::Lobe) << where;
            EXPECT_EQ(r[0].image.data(), env.data()) << where;
            EXPECT_EQ(r[0].plan.predicted_error, 0.0) << where;
            const OffGridError lobe = measure_offgrid_error(env, r[0].image, n, 1024, 3, 2, r[0].plan.lookup);
            EXPECT_LT(lobe.weighted_relative_rms, 1e-6) << where;
            EXPECT_LT(lobe.worst_texel, 1e-5) << where;
            const OffGridError bilinear = measure_offgrid_error(env, r[0].image, n, 1024, 3, 2);
            EXPECT_GT(bilinear.weighted_relative_rms, 0.01) << where;
        }
    // Wider than half a texel on a smooth map: bilinear lookups of a grid the planner sizes (the sun
    // map's finest grid misses the worst-texel share there and falls back to the lobe lookup, see
    // the next test); a fixed size: that grid.
    const HdrImage smooth = sampled(64, 32, smooth_field);
    EXPECT_EQ(convolve(smooth, {MapRequest::make_phong(300, "wide")}, Options{})[0].plan.lookup, MapLookup::Bilinear);
    Options fixed;
    fixed.size = Size{64, 32};
    EXPECT_EQ(convolve(env, {MapRequest::make_phong(1e6, "fixed")}, fixed)[0].plan.lookup, MapLookup::Bilinear);
}

TEST(OutputGrid, ALobeUnderATexelIsNotResampledFromAGridThatBarelyResolvesIt) {
    // A lobe 0.57 of the input's texel wide (n = 1280 on 128x64, as n = 20480 on 512x256) over
    // plateaus of 10:1 from texel to texel: twice the input's height (256x128) samples it at 0.875
    // lobe widths, where the fourth differences under-predict 4-point resampling (courtyard's
    // 512x256 map erred 5.8 % against a predicted 2 %). The map is summed again on a grid within
    // 0.75 lobe widths instead, and its texels are within the 5 % worst-texel target of exact.
    std::mt19937 rng(12);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    HdrImage plateaus(128, 64);
    for (int j = 0; j < 64; ++j)
        for (int i = 0; i < 128; ++i) {
            const float v = u(rng) < 0.3f ? 10.0f : 1.0f;
            plateaus.set(i, j, {v, 0.8f * v, 0.6f * v});
        }
    for (const bool tiles : {false, true}) {
        Options o;
        o.threads = 2;
        o.fine_tiles = tiles;
        const auto r = convolve(plateaus, {MapRequest::make_phong(1280, "1280")}, o);
        ASSERT_EQ(r[0].plan.lookup, MapLookup::Bilinear) << r[0].plan.size_reason;
        EXPECT_NE(r[0].plan.size_reason.find("256x128 does not resolve the lobe"), std::string::npos)
            << r[0].plan.size_reason;
        EXPECT_TRUE(r[0].fine.empty()) << "a map summed again gets the whole grid";
        Options exact;
        exact.method = Method::Exact;
        exact.threads = 2;
        exact.size = Size{r[0].image.width(), r[0].image.height()};
        const auto want = convolve(plateaus, {MapRequest::make_phong(1280, "1280")}, exact);
        const MapError e = compare_maps(r[0].image, want[0].image);
        std::printf("[  report  ] plateaus 128x64 n 1280: %dx%d, worst %.4f, rms %.2e (%s)\n", r[0].image.width(),
                    r[0].image.height(), e.worst_texel, e.weighted_relative_rms, r[0].plan.size_reason.c_str());
        EXPECT_LT(e.worst_texel, 0.05);
        EXPECT_LT(e.weighted_relative_rms, o.tolerance);
    }
}

// A lobe between half a texel and one (n = 300 on 64x32: 103 < n < 415) over texel-to-texel
// contrast: where bilinear lookups of every grid the planner may deliver miss the tolerance, the
// map falls back to the lobe lookup and is exact off-grid; where they meet it, it stays bilinear.
TEST(OutputGrid, ALobeUnderATexelFallsBackToTheLobeLookupWhereBilinearGridsMiss) {
    std::mt19937 rng(4);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    HdrImage noise(64, 32);
    for (int j = 0; j < 32; ++j)
        for (int i = 0; i < 64; ++i) {
            const float v = u(rng) < 0.5f ? 0.01f : 1.0f;  // 100:1 from texel to texel
            noise.set(i, j, {v, v * u(rng), v});
        }
    for (const double tau : {0.01, 0.001}) {
        Options o;
        o.tolerance = tau;
        const auto r = convolve(noise, {MapRequest::make_phong(300, "sharp")}, o);
        const OffGridError e = measure_offgrid_error(noise, r[0].image, 300, 2048, 8, 2, r[0].plan.lookup);
        std::printf("[  report  ] noise 64x32 n 300 tau %g: lookup %s, %dx%d, predicted %.4f, off-grid %.2e (%s)\n", tau,
                    to_string(r[0].plan.lookup), r[0].image.width(), r[0].image.height(), r[0].plan.predicted_error,
                    e.weighted_relative_rms, r[0].plan.size_reason.c_str());
        EXPECT_LE(r[0].plan.predicted_error, tau);
        EXPECT_LE(e.weighted_relative_rms, tau + 3 * e.rms_standard_error);
        // At 1 % a grid 8x finer (512x256) meets it; at 0.1 % the finest allowed misses (0.2 %).
        EXPECT_EQ(r[0].plan.lookup, tau == 0.01 ? MapLookup::Bilinear : MapLookup::Lobe);
        if (r[0].plan.lookup == MapLookup::Lobe) {
            EXPECT_EQ(r[0].image.data(), noise.data());
            EXPECT_LT(e.weighted_relative_rms, 1e-6);
        }
        // A second map of the same lobe shares the first's work and must share its whole plan,
        // the fallback's lookup included.
        const auto twice =
            convolve(noise, {MapRequest::make_phong(300, "a"), MapRequest::make_phong(300, "b")}, o);
        EXPECT_EQ(twice[1].plan.shares_with, twice[0].request.label);
        EXPECT_EQ(twice[1].plan.lookup, twice[0].plan.lookup);
        EXPECT_EQ(twice[1].plan.method, twice[0].plan.method);
        EXPECT_EQ(twice[1].image.data(), twice[0].image.data());
    }
}

// Before any grid is summed for a lobe between half a texel and one, its exact map is measured on
// the finest grid the plan may deliver round the input's roughest texels (spot_lookup_worst):
// where that already misses the worst-texel share, the map goes to the lobe lookup at once (on
// 1024x512 maps n = 5e4-1e5 summed a 2048x1024 grid only to fall back: 0.4-0.7 s against
// 0.03-0.07 s). The spots see what the whole grid would: never more, and most of it.
TEST(OutputGrid, ALobeUnderATexelWhoseFinestGridMissesAtItsRoughestTexelsIsNotSummed) {
    const auto plateaus = [](int w, int h, float contrast, unsigned seed) {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        HdrImage map(w, h);
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) {
                const float v = u(rng) < 0.3f ? contrast : 1.0f;
                map.set(i, j, {v, 0.7f * v, 0.5f * v});
            }
        return map;
    };
    // The spots against the whole grid's own measure (64x32, lobes 0.8 and 0.5 of a texel wide;
    // half a texel is n = 415 there).
    const HdrImage small = plateaus(64, 32, 100.0f, 21);
    for (const double n : {250.0, 400.0})
        for (const Size grid : {Size{128, 64}, Size{512, 256}}) {
            const double spots = spot_lookup_worst(small, n, grid, 32, 2);
            const LookupError whole = estimate_lookup_error(resample_lobe(small, grid.width, grid.height, n, 2), 2);
            std::printf("[  report  ] plateaus 64x32 n %g on %dx%d: spots %.4f, whole grid %.4f\n", n, grid.width,
                        grid.height, spots, whole.between_worst);
            EXPECT_LE(spots, whole.between_worst * (1 + 1e-6));
            EXPECT_GE(spots, 0.5 * whole.between_worst);
        }
    // Small lamps on a smooth sky at 1024x512 (the finest grid allowed, 2048 rows, is 4x the
    // input's) and n = 1e5, 0.51 of a texel wide: the lobe lookup, the input's texels, with no
    // grid summed. (On random plateaus the roughest texels are too many alike for 32 spots to
    // find the worst, and the map is summed as before.)
    HdrImage big = sampled(1024, 512, smooth_field);
    std::mt19937 rng(22);
    for (int lamp = 0; lamp < 20; ++lamp) {  // single texels 50x the sky round them
        const int i = int(rng() % 1024), j = 32 + int(rng() % 448);
        const Rgb v = big.at(i, j);
        big.set(i, j, {50 * v.r, 50 * v.g, 50 * v.b});
    }
    Options o;
    o.threads = 2;
    const double n = 1e5;
    const auto r = convolve(big, {MapRequest::make_phong(n, "sharp")}, o);
    ASSERT_EQ(r[0].plan.lookup, MapLookup::Lobe) << r[0].plan.size_reason;
    EXPECT_NE(r[0].plan.size_reason.find("no grid summed"), std::string::npos) << r[0].plan.size_reason;
    EXPECT_EQ(r[0].image.data(), big.data());
    const OffGridError e = measure_offgrid_error(big, r[0].image, n, 256, 5, 2, r[0].plan.lookup);
    EXPECT_LT(e.worst_texel, 1e-5);
    // A smooth map finds nothing at its spots and is summed as planned: bilinear lookups.
    const HdrImage smooth = sampled(64, 32, smooth_field);
    const auto s = convolve(smooth, {MapRequest::make_phong(400, "smooth")}, o);
    EXPECT_EQ(s[0].plan.lookup, MapLookup::Bilinear) << s[0].plan.size_reason;
}

TEST(OutputGrid, ShininessAboveTheLimitIsRefusedNamingTheMirror) {
    const HdrImage env = sampled(16, 8, smooth_field);
    try {
        convolve(env, {MapRequest::make_phong(2e7, "2e7")}, Options{});
        FAIL() << "n = 2e7 was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("mirror"), std::string::npos) << e.what();
    }
}


// The bright split takes the same solid angle of bright sources out at every input size: a lamp
// of 1600 texels at 2048x1024 (400 at 1024x512) is split whole, not cut at the 1024 brightest
// (the rest stayed in the remainder, whose coarser levels moved it: a 10 % texel on studio).
TEST(OutputGrid, TheBrightSplitsCapGrowsWithTheInputsTexels) {
    const PlannerModel model;
    EXPECT_EQ(bright_texel_cap(model, 512, 256), model.max_bright_texels);
    EXPECT_EQ(bright_texel_cap(model, 1024, 512), model.max_bright_texels);
    EXPECT_EQ(bright_texel_cap(model, 2048, 1024), 4 * model.max_bright_texels);
    EXPECT_EQ(bright_texel_cap(model, 8192, 4096), 64 * model.max_bright_texels);
    HdrImage env = sampled(2048, 1024, smooth_field);
    for (int j = 300; j < 340; ++j)
        for (int i = 700; i < 740; ++i) env.set(i, j, {2e4f, 1.6e4f, 1.2e4f});
    Options o;
    o.threads = 2;
    MapRequest q = MapRequest::make_phong(640, "640");
    q.size = Size{256, 128};
    const std::vector<MapResult> r = convolve(env, {q}, o);
    ASSERT_EQ(r.size(), 1u);
    EXPECT_EQ(r[0].plan.bright_texels, 1600) << to_string(r[0].plan.method);
}

// Wide lobes from SH with the bright split: the bright texels projected into SH with the remainder
// (BrightTerms::Auto folds them for n = 10 on a small grid) give the same map as their
// lobes scattered over the grid, and both match the exact sums. Two lamps of 1e3 and 5e3 (164
// texels, one on the seam, one near the north pole) over a smooth floor.
TEST(OutputGrid, BrightTexelsFoldedIntoShMatchTheirScatteredLobes) {
    HdrImage env = sampled(128, 64, smooth_field);
    const auto lamp = [&](int i0, int j0, int size, float v) {
        for (int j = j0; j < j0 + size; ++j)
            for (int i = i0; i < i0 + size; ++i) env.set((i + 128) % 128, j, {v, 0.8f * v, 0.6f * v});
    };
    lamp(-5, 28, 10, 1e3f);
    lamp(40, 2, 8, 5e3f);
    const BrightSplit split = split_bright(env, 64.0, 1024, 2);
    ASSERT_GE(split.texels.size(), 20u);
    constexpr int kOrder = 64;
    const ShLegendre legendre(kOrder);
    const ShCoefficients remainder =
        sh_project(split.remainder, kOrder, 2, ShQuadrature::TexelSolidAngle, ShSummation::Plain);
    const std::vector<double> ones = sh_ones_projection({128, 64}, kOrder, legendre);
    const double mean = max_channel_power(split.remainder) / (4.0 * kPi);
    // The split sums the remainder's power itself (the engine's remainder mean): the same sums,
    // equal up to rounding (a compiler may fuse one side's multiply-add and not the other's).
    EXPECT_DOUBLE_EQ(split.remainder_power, max_channel_power(split.remainder));
    const PreparedLevel full(env, 2);
    for (const double n : {10.0, 20.0}) {
        const Size out{128, 64};
        const int order = 24;
        const ShSplitResult folded = sh_split_convolve(remainder, ones, legendre, mean, split.texels, n, order, out,
                                                       0.01, 1e-4, 2, nullptr, BrightTerms::Auto);
        const ShSplitResult scattered = sh_split_convolve(remainder, ones, legendre, mean, split.texels, n, order, out,
                                                          0.01, 1e-4, 2, nullptr, BrightTerms::Scattered);
        if (n == 10.0) {  // n = 20 folds only with more bright texels
            EXPECT_GT(folded.bright_fold_order, order);
        }
        EXPECT_LE(folded.bright_fold_order, kOrder) << "n = " << n;
        EXPECT_EQ(scattered.bright_fold_order, 0);
        EXPECT_EQ(folded.failed_rows.size(), scattered.failed_rows.size()) << "n = " << n;
        double worst = 0;
        for (std::size_t v = 0; v < folded.image.data().size(); ++v) {
            const double a = folded.image.data()[v], b = scattered.image.data()[v];
            worst = std::max(worst, std::abs(a - b) / std::max(std::abs(b), 1e-30));
        }
        EXPECT_LT(worst, 5e-4) << "n = " << n;  // the scatter's cut (1e-4 of the floor) and float rounding
        const HdrImage exact = exact_convolve(full, n, out, 2, [](long long) {});
        const MapError e = compare_maps(folded.image, exact);
        EXPECT_LT(e.weighted_relative_rms, 1e-3) << "n = " << n;
        EXPECT_LT(e.worst_texel, 5e-3) << "n = " << n;
    }
}

}  // namespace
}  // namespace glint::convolution
