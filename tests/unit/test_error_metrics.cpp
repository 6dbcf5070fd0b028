// Tests of core/error_metrics against values computed by hand from docs/conventions.md.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <utility>

#include "appliance/core/equirect.hpp"
#include "appliance/core/error_metrics.hpp"

namespace glint {
namespace {

HdrImage constant(int w, int h, float v) {
    HdrImage img(w, h);
    for (float& x : img.data()) x = v;
    return img;
}

HdrImage noise(int w, int h, unsigned seed) {
    HdrImage img(w, h);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> dist(0.0f, 10.0f);
    for (float& x : img.data()) x = dist(rng);
    return img;
}

void expect_all_zero(const MapError& e) {
    EXPECT_EQ(e.weighted_relative_rms, 0.0);
    EXPECT_EQ(e.worst_texel, 0.0);
    EXPECT_EQ(e.mean_abs_percent, 0.0);
    EXPECT_EQ(e.max_abs_percent, 0.0);
}

TEST(ErrorMetrics, IdenticalMapsHaveZeroError) {
    const HdrImage a = noise(32, 16, 1);
    expect_all_zero(compare_maps(a, a));
    expect_all_zero(compare_maps(constant(8, 4, 2.0f), constant(8, 4, 2.0f)));
}

TEST(ErrorMetrics, IdenticalBlackMapsHaveZeroErrorNotNaN) {
    // eps = 1e-6 mean(reference) is 0 here: 0 / (0 + 0) must not turn into NaN.
    expect_all_zero(compare_maps(constant(8, 4, 0.0f), constant(8, 4, 0.0f)));
}

TEST(ErrorMetrics, HandComputedValuesOnA4x2Map) {
    // Both rows of a 4x2 map have solid angle (2pi/4)(cos 0 - cos pi/2) = pi/2 per texel.
    HdrImage ref = constant(4, 2, 2.0f);
    ref.set(0, 0, {4, 4, 4});
    HdrImage approx = ref;
    approx.set(1, 1, {3, 2, 2});  // |diff| 1 where the reference is 2
    approx.set(0, 0, {4, 5, 4});  // |diff| 1 where the reference is 4
    const MapError e = compare_maps(approx, ref);

    // sum dOmega |B|^2 = pi/2 (7 texels * 3 * 4 + 3 * 16) = pi/2 * 132; numerator pi/2 * 2.
    EXPECT_NEAR(e.weighted_relative_rms, std::sqrt(2.0 / 132.0), 1e-15);
    // mean|B| = (21 * 2 + 3 * 4) / 24 = 2.25; worst = 1 / max(2, 2.25) (not 1 / max(4, 2.25)).
    EXPECT_NEAR(e.worst_texel, 1.0 / 2.25, 1e-15);
    const double eps = 1e-6 * 2.25;
    const double p1 = 100.0 / (2.0 + eps);
    const double p2 = 100.0 / (4.0 + eps);
    EXPECT_NEAR(e.max_abs_percent, p1, 1e-12);
    EXPECT_NEAR(e.mean_abs_percent, (p1 + p2) / 24.0, 1e-12);
}

TEST(ErrorMetrics, RmsIsWeightedBySolidAngle) {
    // 2x4 map: the polar rows 0 and 3 hold pi(1 - sqrt(2)/2) per texel, the middle rows
    // pi sqrt(2)/2. An error of 1 in all of row 0 on a reference of 1 everywhere:
    //   num = 2 texels * 3 channels * pi (1 - sqrt(2)/2),   den = 3 * 4 pi.
    const HdrImage ref = constant(2, 4, 1.0f);
    HdrImage approx = ref;
    approx.set(0, 0, {2, 2, 2});
    approx.set(1, 0, {2, 2, 2});
    const MapError e = compare_maps(approx, ref);
    EXPECT_NEAR(e.weighted_relative_rms, std::sqrt((1.0 - std::sqrt(2.0) / 2.0) / 2.0), 1e-15);
    // The percentages are not weighted: 6 of 24 values are 100 / (1 + 1e-6) % off.
    EXPECT_NEAR(e.mean_abs_percent, 6.0 / 24.0 * 100.0 / (1.0 + 1e-6), 1e-12);
    EXPECT_NEAR(e.max_abs_percent, 100.0 / (1.0 + 1e-6), 1e-12);
    EXPECT_NEAR(e.worst_texel, 1.0, 1e-15);

    // The same error in an equatorial row weighs more.
    HdrImage approx_mid = ref;
    approx_mid.set(0, 1, {2, 2, 2});
    approx_mid.set(1, 1, {2, 2, 2});
    EXPECT_NEAR(compare_maps(approx_mid, ref).weighted_relative_rms,
                std::sqrt((std::sqrt(2.0) / 2.0) / 2.0), 1e-15);
}

TEST(ErrorMetrics, ReferenceIsTheSecondArgument) {
    const HdrImage b = constant(4, 2, 1.0f);
    const HdrImage a = constant(4, 2, 2.0f);
    EXPECT_NEAR(compare_maps(a, b).weighted_relative_rms, 1.0, 1e-15);
    EXPECT_NEAR(compare_maps(b, a).weighted_relative_rms, 0.5, 1e-15);
    EXPECT_NEAR(compare_maps(a, b).worst_texel, 1.0, 1e-15);
    EXPECT_NEAR(compare_maps(b, a).worst_texel, 0.5, 1e-15);
}

TEST(ErrorMetrics, ConstantOfAnotherSizeHasExactlyZeroError) {
    const HdrImage ref = constant(64, 32, 0.7f);
    for (const auto& [w, h] : {std::pair{8, 4}, std::pair{300, 200}, std::pair{7, 3}})
        expect_all_zero(compare_maps(constant(w, h, 0.7f), ref));
}

TEST(ErrorMetrics, ApproxOfAnotherSizeIsResampledBilinearly) {
    const HdrImage ref = noise(16, 8, 2);
    const HdrImage approx = noise(40, 20, 3);
    const MapError direct = compare_maps(approx, ref);
    const MapError resampled = compare_maps(resample_bilinear(approx, 16, 8), ref);
    EXPECT_EQ(direct.weighted_relative_rms, resampled.weighted_relative_rms);
    EXPECT_EQ(direct.worst_texel, resampled.worst_texel);
    EXPECT_EQ(direct.mean_abs_percent, resampled.mean_abs_percent);
    EXPECT_EQ(direct.max_abs_percent, resampled.max_abs_percent);
    EXPECT_GT(direct.weighted_relative_rms, 0.0);

    // A coarse map that is the upsampled reference's exact bilinear source: the 8x4
    // map resampled to 16x8 and compared against that resampling gives 0.
    const HdrImage coarse = noise(8, 4, 4);
    expect_all_zero(compare_maps(coarse, resample_bilinear(coarse, 16, 8)));
}

TEST(ErrorMetrics, ALobeMapIsReadThroughItsLobeWhateverTheSizes) {
    // A lobe-lookup map holds radiance: against its own lobe's values at another grid's centres,
    // and at its own, it is exact only when read through the lobe.
    // n = 200: a lobe of about one texel of this 64x32 map, so even at the map's own texel
    // centres the lobe's value is not the texel's.
    const HdrImage radiance = noise(64, 32, 5);
    const double n = 200;
    for (const auto& [w, h] : {std::pair{23, 11}, std::pair{64, 32}}) {
        const HdrImage sums = resample_lobe(radiance, w, h, n);
        expect_all_zero(compare_maps(radiance, sums, MapLookup::Lobe, n));
        EXPECT_GT(compare_maps(radiance, sums, MapLookup::Bilinear, n).weighted_relative_rms, 1e-3) << w << "x" << h;
    }
    // Bilinear through the overload is the bilinear resampling's error.
    const HdrImage ref = noise(16, 8, 2);
    EXPECT_EQ(compare_maps(radiance, ref, MapLookup::Bilinear, 0.0).weighted_relative_rms,
              compare_maps(resample_bilinear(radiance, 16, 8), ref).weighted_relative_rms);
}

}  // namespace
}  // namespace glint
