// The cone's Fourier first pass (fourier_pass.hpp) against LobeSummer::sum_row with double
// accumulation: the same terms, so the same sums to rounding, on rough maps (texels spread
// over four decades), with and without merged polar columns, output widths 1, 1/2 and 1/4 of
// the level's, narrow and wide lobes (the wide ones put whole rows near the poles into the
// cone, the kernel-transform branch).
#include "appliance/convolution/fourier_pass.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "appliance/convolution/lobe_sum.hpp"
#include "appliance/convolution/methods.hpp"
#include "appliance/convolution/sh.hpp"
#include "appliance/core/errors.hpp"

namespace glint::convolution {
namespace {

// Texels spread over four decades; every fifth column block and a polar cap black, so that some
// output texels' true sums are exactly 0 (the direct sums give 0 there).
HdrImage rough_map(int width, int height, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> decade(-2.0f, 2.0f);
    HdrImage image(width, height);
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i) {
            const bool black = (i / std::max(1, width / 16)) % 5 == 2 || j < height / 16;
            if (!black)
                image.set(i, j, {std::pow(10.0f, decade(rng)), std::pow(10.0f, decade(rng)), std::pow(10.0f, decade(rng))});
        }
    return image;
}

// The largest difference of two maps' values, relative to the larger, floored at a's mean value
// (as the error metric does).
double worst_apart(const HdrImage& a, const HdrImage& b) {
    double mean = 0;
    for (float v : a.data()) mean += v;
    mean /= double(a.data().size());
    double worst = 0;
    for (std::size_t k = 0; k < a.data().size(); ++k) {
        const double x = a.data()[k], y = b.data()[k];
        worst = std::max(worst, std::abs(x - y) / std::max({x, y, mean}));
    }
    return worst;
}

struct Case {
    int width, height, out_width;
    double shininess, cut_energy, merged_arc;
    // Merged polar columns only where the level is smooth (polar_merge_factors), on a map whose
    // northern half is one colour: its polar rows merge and their southern mirrors do not.
    bool smooth_north = false;
};


class FourierPass : public ::testing::TestWithParam<Case> {};

TEST_P(FourierPass, SumsWhatSumRowSums) {
    const Case c = GetParam();
    HdrImage image = rough_map(c.width, c.height, unsigned(c.width * 7 + c.out_width));
    if (c.smooth_north)
        for (int j = 0; j < c.height / 2; ++j)
            for (int i = 0; i < c.width; ++i) image.set(i, j, {2.0f, 1.0f, 0.5f});
    const PreparedLevel level(image, 2);
    const int out_h = c.out_width / 2;
    const LobeSummer summer(level, c.out_width, out_h, c.shininess, Accumulation::Double, c.merged_arc,
                            c.smooth_north ? 0.01 : std::numeric_limits<double>::infinity());
    ASSERT_TRUE(FourierFirstPass::applies(c.width, c.height, c.out_width));
    ASSERT_EQ(summer.classes(), 1);
    const double c0 = cone_cut_cos(c.cut_energy, c.shininess);

    // The wide levels only near the poles, where the kernels are widest (the direct reference
    // sums of a 20-wide lobe over every row would take seconds).
    std::vector<int> rows;
    for (int r = 0; r < out_h; ++r)
        if (c.width < 512 || r < 12 || r >= out_h - 12) rows.push_back(r);
    LobeSums direct = summer.make_sums(&rows);
    for (int r : rows) summer.sum_row(r, c0, direct);
    LobeSums fourier = summer.make_sums(&rows);
    std::atomic<int> progress{0};
    const int paired =
        FourierFirstPass(summer, c.out_width, 2).run(rows, c0, fourier, [&](long long k) { progress += int(k); });
    EXPECT_EQ(progress.load(), int(rows.size()));
    // A row and its mirror share their kernels' spectra unless they read different versions of
    // the level (merged columns where one side is rough): then each is summed on its own.
    if (c.smooth_north) {
        EXPECT_GT(paired, 0);
        EXPECT_LT(paired, int(rows.size())) << "no row summed on its own: the fallback is not tested";
    } else {
        EXPECT_EQ(paired, int(rows.size()));
    }

    double worst = 0;
    long long zeros = 0;
    for (int r : rows) {
        EXPECT_NEAR(fourier.den[std::size_t(r)], direct.den[std::size_t(r)], 1e-12 * direct.den[std::size_t(r)]) << r;
        EXPECT_EQ(fourier.cmax[std::size_t(r)], direct.cmax[std::size_t(r)]) << r;
        // Rounding of a transform is relative to the row's largest sums, not to each texel's.
        double row_max = 0;
        for (int q = 0; q < c.out_width; ++q)
            for (int ch = 0; ch < 3; ++ch) row_max = std::max(row_max, direct.num[direct.texel(r, q) * 3 + std::size_t(ch)]);
        for (int q = 0; q < c.out_width; ++q)
            for (int ch = 0; ch < 3; ++ch) {
                const double a = fourier.num[fourier.texel(r, q) * 3 + std::size_t(ch)];
                const double b = direct.num[direct.texel(r, q) * 3 + std::size_t(ch)];
                worst = std::max(worst, std::abs(a - b) / row_max);
                if (b == 0) {  // a black region the lobe sees alone
                    ++zeros;
                    EXPECT_EQ(a, 0.0) << r << " " << q;
                }
            }
    }
    EXPECT_LT(worst, 1e-11);
    if (c.shininess >= 2000) {
        EXPECT_GT(zeros, 0) << "no black texel seen alone: the clean-up is not tested";
    }
}

// Two summers that merge different rows near the poles share the level's merged version (which
// makes only the rows its readers flag) and its spectra: the second summer's rows, made after the
// first summer's pass transformed their group, are transformed from their made values.
TEST(FourierPass, MergedRowsMadeLaterAreTransformedWhenMade) {
    const HdrImage image = rough_map(256, 128, 12);
    const PreparedLevel level(image, 2);
    const int out_w = 128, out_h = 64;
    std::vector<int> rows;
    for (int r = 0; r < out_h; ++r) rows.push_back(r);
    // Rows with sin(theta) <= 0.41 merged (m = 2), then (made only now) every row.
    const LobeSummer few(level, out_w, out_h, 2000, Accumulation::Double, 0.02);
    LobeSums first = few.make_sums(&rows);
    FourierFirstPass(few, out_w, 2).run(rows, cone_cut_cos(1e-3, 2000), first, nullptr);
    const LobeSummer more(level, out_w, out_h, 300, Accumulation::Double, 0.06);
    const double c0 = cone_cut_cos(1e-3, 300);
    LobeSums direct = more.make_sums(&rows), fourier = more.make_sums(&rows);
    for (int r : rows) more.sum_row(r, c0, direct);
    FourierFirstPass(more, out_w, 2).run(rows, c0, fourier, nullptr);
    double worst = 0, largest = 0;
    for (double v : direct.num) largest = std::max(largest, std::abs(v));
    for (std::size_t k = 0; k < direct.num.size(); ++k) worst = std::max(worst, std::abs(fourier.num[k] - direct.num[k]));
    EXPECT_LT(worst, 1e-11 * largest);
}

// The cone with and without the Fourier first pass: the same map to within the cut-off's error,
// and with it (a cone dropping far less of the lobe) fewer texels summed again.
TEST(FourierPass, ConeWithAndWithoutItAgree) {
    const HdrImage image = rough_map(256, 128, 9);
    const PreparedLevel level(image, 2);
    const Size out{128, 64};
    for (double n : {300.0, 3000.0}) {
        ConeSettings settings;
        settings.cutoff_energy = 1e-3;
        settings.texel_tolerance = 5e-3;
        ConeStats on_stats, off_stats;
        const HdrImage on = cone_convolve(level, {}, n, out, settings, 2, nullptr, &on_stats);
        settings.fourier_first_pass = false;
        const HdrImage off = cone_convolve(level, {}, n, out, settings, 2, nullptr, &off_stats);
        EXPECT_TRUE(on_stats.fourier_first_pass);
        EXPECT_FALSE(off_stats.fourier_first_pass);
        EXPECT_EQ(on_stats.cutoff_energy, settings.fourier_cutoff_energy);
        EXPECT_EQ(off_stats.cutoff_energy, 1e-3);
        EXPECT_LE(on_stats.refined_texels, off_stats.refined_texels);
        // Both within the per-texel bound of the exact sums at this level, so within twice it of
        // each other.
        EXPECT_LT(worst_apart(on, off), 2 * settings.texel_tolerance) << n;
    }
}

// A grid summed in bands of rows (what cone_convolve does past kConeBandTexels) against one call
// over every row and against the exact sums, on a rough map with suns (bright texels scattered
// exactly): each band's bounds take its own smallest output, so the maps may differ, but each
// stays within its per-texel bound of exact; on this map the two differ by at most 7e-4 even
// with the smallest bands (a row and its mirror), so a band that lost its bounds shows. The
// texels summed again are counted over the bands; the Fourier and the direct first pass both.
TEST(FourierPass, ConeSummedInBandsAgreesWithOneCall) {
    HdrImage image = rough_map(256, 128, 21);
    for (const auto& [i, j] : {std::pair{40, 60}, std::pair{200, 20}, std::pair{128, 110}})
        image.set(i, j, {2e5f, 1.5e5f, 1e5f});
    const BrightSplit split = split_bright(image, 64.0, 1024, 2);
    ASSERT_GE(split.texels.size(), 3u);
    const PreparedLevel level(split.remainder, 2);
    const Size out{128, 64};
    const PreparedLevel full(image, 2);
    for (const bool fourier : {true, false})
        for (double n : {300.0, 3000.0}) {
            ConeSettings settings;
            settings.cutoff_energy = 1e-3;
            settings.texel_tolerance = 5e-3;
            settings.bright_tolerance = 5e-3;
            settings.fourier_first_pass = fourier;
            ConeStats whole_stats, band_stats;
            const HdrImage whole = cone_convolve(level, split.texels, n, out, settings, 2, nullptr, &whole_stats);
            const HdrImage exact = exact_convolve(full, n, out, 2, nullptr);
            for (const int band_rows : {1, 7}) {
                std::atomic<long long> rows_done{0};
                const HdrImage banded = cone_convolve_in_bands(
                    level, split.texels, n, out, settings, 2, [&](long long r) { rows_done += r; }, &band_stats, band_rows);
                EXPECT_EQ(rows_done.load(), out.height) << "every row's progress once, over the bands";
                EXPECT_EQ(band_stats.fourier_first_pass, whole_stats.fourier_first_pass);
                EXPECT_GT(band_stats.refined_texels, 0) << "no texel summed again: the bands' bounds are not tested";
                for (float v : banded.data()) ASSERT_TRUE(std::isfinite(v) && v >= 0);
                const std::string what = std::to_string(n) + (fourier ? " fourier" : " direct") + ", bands of " +
                                         std::to_string(band_rows);
                EXPECT_LT(worst_apart(whole, banded), 2e-3) << what;
                EXPECT_LT(worst_apart(exact, banded), settings.texel_tolerance) << what;
            }
            EXPECT_LT(worst_apart(exact, whole), settings.texel_tolerance);
        }
    EXPECT_THROW(cone_convolve_in_bands(level, split.texels, 300, out, ConeSettings{}, 1, nullptr, nullptr, 0),
                 RuntimeError);
}

// A level's layouts freed (the engine does so when a map that was the level's last reader has
// summed its grid) are made again when read: the same sums as before, for the direct first pass
// (phase layouts, merged polar columns) and the Fourier one (row spectra).
TEST(FourierPass, ReleasedLayoutsAreMadeAgainTheSame) {
    const HdrImage image = rough_map(256, 128, 5);
    const PreparedLevel level(image, 2);
    const int out_w = 128, out_h = 64;
    std::vector<int> rows;
    for (int r = 0; r < out_h; ++r) rows.push_back(r);
    const double c0 = cone_cut_cos(1e-3, 2000);
    const auto sums_of = [&](bool fourier) {
        const LobeSummer summer(level, out_w, out_h, 2000, Accumulation::Double, 0.05);
        LobeSums sums = summer.make_sums(&rows);
        if (fourier) {
            FourierFirstPass(summer, out_w, 2).run(rows, c0, sums, nullptr);
        } else {
            summer.lay_out();
            for (int r : rows) summer.sum_row(r, c0, sums);
        }
        return std::vector<double>(sums.num.begin(), sums.num.end());
    };
    for (const bool fourier : {false, true}) {
        const std::vector<double> before = sums_of(fourier);
        // The direct pass holds a phase layout and a merged version, the Fourier one its spectra.
        EXPECT_GE(level.layouts_held(), fourier ? 1u : 2u) << (fourier ? "fourier" : "direct");
        level.release_layouts();
        EXPECT_EQ(level.layouts_held(), 0u) << "nothing freed";
        const std::vector<double> after = sums_of(fourier);
        EXPECT_EQ(before, after) << (fourier ? "fourier" : "direct");
        level.release_layouts();
    }
    level.release_layouts();  // nothing built: nothing to free
    EXPECT_EQ(level.layouts_held(), 0u);
}

INSTANTIATE_TEST_SUITE_P(
    Shapes, FourierPass,
    ::testing::Values(Case{128, 64, 128, 300, 1e-3, 0}, Case{128, 64, 64, 300, 1e-3, 0},
                      Case{256, 128, 64, 2000, 1e-4, 0}, Case{256, 128, 128, 20000, 1e-3, 0},
                      Case{128, 64, 64, 20, 1e-3, 0},  // wide: whole rows near the poles
                      Case{256, 128, 128, 2000, 1e-3, 0.05},  // merged polar columns
                      Case{64, 32, 32, 5, 1e-2, 0},
                      // Kernels wider than the cosine table (256 columns) near the poles, output
                      // centres halfway between columns: the kernel-transform branch with its phase.
                      Case{512, 256, 256, 20, 1e-3, 0},
                      // Only the pole rows merged: a row near a pole reads the merged version's
                      // whole-row kernel, then the level's; the second's H was looked up at an
                      // index scaled by the wrong version's bins (20 % off before 2026-12-06).
                      Case{512, 256, 256, 20, 1e-3, 5e-4},
                      // Polar rows merged in the smooth north, not in the rough south: those
                      // mirrored rows are summed each on its own, the rest in pairs.
                      Case{256, 128, 128, 2000, 1e-3, 0.05, true}));

TEST(FourierPass, AppliesToPowerOfTwoWidthsNoWiderThanTheLevel) {
    EXPECT_FALSE(FourierFirstPass::applies(96, 48, 64));    // not a power of two
    EXPECT_FALSE(FourierFirstPass::applies(128, 64, 96));
    EXPECT_FALSE(FourierFirstPass::applies(128, 64, 256));  // finer than the level: several column classes
    EXPECT_TRUE(FourierFirstPass::applies(128, 64, 32));
    EXPECT_TRUE(FourierFirstPass::applies(128, 64, 128));
    EXPECT_TRUE(FourierFirstPass::applies(2048, 1024, 512));
    EXPECT_TRUE(FourierFirstPass::applies(4096, 2048, 2048));   // an 8192x4096 input's n = 20480: 200 MB of spectra
    EXPECT_FALSE(FourierFirstPass::applies(8192, 4096, 4096));  // its spectra would take 800 MB
    // The cone uses it from half the level's columns up.
    EXPECT_TRUE(FourierFirstPass::pays_off(1024, 512, 512));
    EXPECT_TRUE(FourierFirstPass::pays_off(128, 64, 128));
    EXPECT_FALSE(FourierFirstPass::pays_off(1024, 512, 256));
    EXPECT_FALSE(FourierFirstPass::pays_off(96, 48, 48));
    const HdrImage image = rough_map(128, 64, 2);
    const PreparedLevel level(image);
    EXPECT_THROW(FourierFirstPass(LobeSummer(level, 256, 128, 100), 256, 1), RuntimeError);
}

// The SH projection of auto's split reads the same spectra when a cone map has made them: its
// coefficients are those of the projection from the texels, to rounding.
TEST(FourierPass, ShProjectionFromTheLevelsSpectraMatchesTheTexels) {
    const HdrImage image = rough_map(128, 64, 5);
    const PreparedLevel level(image, 2);
    for (ShSummation summation : {ShSummation::Plain, ShSummation::Compensated}) {
        const ShCoefficients direct = sh_project(image, 40, 2, ShQuadrature::TexelSolidAngle, summation);
        const ShCoefficients shared = sh_project_spectra(
            128, 64, 40, 2, [&](int row) { return level.row_spectrum(row); }, ShQuadrature::TexelSolidAngle,
            summation);
        ASSERT_EQ(shared.rgb.size(), direct.rgb.size());
        double largest = 0, worst = 0;
        for (double v : direct.rgb) largest = std::max(largest, std::abs(v));
        for (std::size_t k = 0; k < direct.rgb.size(); ++k) worst = std::max(worst, std::abs(shared.rgb[k] - direct.rgb[k]));
        EXPECT_LT(worst, 1e-12 * largest);
    }
    EXPECT_THROW(sh_project_spectra(96, 48, 10, 1, [&](int) { return level.row_spectrum(0); }), InputError);
}

}  // namespace
}  // namespace glint::convolution
