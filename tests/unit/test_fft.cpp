// Radix-2 FFT plans against the direct DFT, for every power-of-two length from 1 to 4096.
#include "appliance/convolution/fft.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstddef>
#include <numbers>
#include <random>
#include <vector>

#include "appliance/core/errors.hpp"

namespace glint::convolution {
namespace {

using Complex = std::complex<double>;

// sum_j x_j e^(sign 2 pi i j k / n) in long double, the angle reduced exactly (j k mod n) in integers.
std::vector<Complex> direct_dft(const std::vector<Complex>& x, int sign) {
    const std::size_t n = x.size();
    const long double two_pi = 2 * 3.141592653589793238462643383279502884L;
    std::vector<long double> c(n), s(n);
    for (std::size_t t = 0; t < n; ++t) {
        const long double angle = two_pi * static_cast<long double>(t) / static_cast<long double>(n);
        c[t] = std::cos(angle);
        s[t] = sign * std::sin(angle);
    }
    std::vector<Complex> out(n);
    for (std::size_t k = 0; k < n; ++k) {
        long double re = 0, im = 0;
        for (std::size_t j = 0; j < n; ++j) {
            const std::size_t t = (j * k) % n;
            const long double xr = x[j].real(), xi = x[j].imag();
            re += xr * c[t] - xi * s[t];
            im += xr * s[t] + xi * c[t];
        }
        out[k] = {double(re), double(im)};
    }
    return out;
}

// Largest |a - b| relative to the largest |b|.
double relative_error(const std::vector<Complex>& a, const std::vector<Complex>& b) {
    double err = 0, scale = 0;
    for (std::size_t k = 0; k < b.size(); ++k) {
        err = std::max(err, std::abs(a[k] - b[k]));
        scale = std::max(scale, std::abs(b[k]));
    }
    return err / scale;
}

std::vector<Complex> random_signal(std::size_t n, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<Complex> x(n);
    for (Complex& v : x) v = {u(rng), u(rng)};
    return x;
}

TEST(Fft, ComplexMatchesDirectDft) {
    for (std::size_t n = 1; n <= 4096; n *= 2) {
        const FftPlan plan(n);
        ASSERT_EQ(plan.size(), n);
        const std::vector<Complex> x = random_signal(n, unsigned(n));
        std::vector<Complex> f = x;
        plan.forward(f.data());
        EXPECT_LT(relative_error(f, direct_dft(x, -1)), 1e-12) << "forward, n " << n;
        std::vector<Complex> g = x;
        plan.inverse(g.data());
        EXPECT_LT(relative_error(g, direct_dft(x, +1)), 1e-12) << "inverse, n " << n;
        // Round trip: inverse(forward(x)) = n x.
        plan.inverse(f.data());
        for (Complex& v : f) v /= double(n);
        EXPECT_LT(relative_error(f, x), 1e-12) << "round trip, n " << n;
    }
}

TEST(Fft, RealMatchesDirectDft) {
    for (std::size_t n = 1; n <= 4096; n *= 2) {
        const RealFftPlan plan(n);
        ASSERT_EQ(plan.size(), n);
        ASSERT_EQ(plan.spectrum_size(), n / 2 + 1);
        std::vector<Complex> x = random_signal(n, 100u + unsigned(n));
        std::vector<double> real(n);
        for (std::size_t j = 0; j < n; ++j) {
            real[j] = x[j].real();
            x[j] = {real[j], 0.0};
        }
        const std::vector<Complex> want = direct_dft(x, -1);
        std::vector<Complex> spectrum(plan.spectrum_size());
        plan.forward(real.data(), spectrum.data());
        const std::vector<Complex> want_half(want.begin(), want.begin() + long(n / 2 + 1));
        EXPECT_LT(relative_error(spectrum, want_half), 1e-12) << "forward, n " << n;

        // Inverse of a random half spectrum (the imaginary parts at 0 and n/2 must be ignored) against the
        // direct inverse DFT of its conjugate-symmetric extension.
        const std::vector<Complex> half = random_signal(n / 2 + 1, 200u + unsigned(n));
        std::vector<Complex> full(n);
        for (std::size_t k = 0; k < n; ++k) full[k] = 2 * k <= n ? half[k] : std::conj(half[n - k]);
        full[0] = half[0].real();
        if (n > 1) full[n / 2] = half[n / 2].real();
        const std::vector<Complex> back = direct_dft(full, +1);
        std::vector<Complex> work = half;
        std::vector<double> out(n);
        plan.inverse(work.data(), out.data());
        std::vector<Complex> got(n);
        for (std::size_t j = 0; j < n; ++j) got[j] = out[j];
        EXPECT_LT(relative_error(got, back), 1e-12) << "inverse, n " << n;

        // Round trip.
        std::vector<double> again(n);
        plan.inverse(spectrum.data(), again.data());
        double worst = 0;
        for (std::size_t j = 0; j < n; ++j) worst = std::max(worst, std::abs(again[j] / double(n) - real[j]));
        EXPECT_LT(worst, 1e-12) << "round trip, n " << n;
    }
}

// The batched real transform (one signal per vector lane) against forward() of each signal, for
// every length from 1 to 4096 and 1, 5 and 8 signals; lanes past count are not written.
TEST(Fft, RealBatchMatchesOneByOne) {
    std::mt19937 rng(17);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (std::size_t n = 1; n <= 4096; n *= 2) {
        const RealFftPlan plan(n);
        const std::size_t bins = plan.spectrum_size();
        for (std::size_t count : {std::size_t(1), std::size_t(5), FftPlan::kBatch}) {
            std::vector<std::vector<float>> signals(count, std::vector<float>(n));
            for (auto& s : signals)
                for (float& v : s) v = u(rng);
            std::vector<std::vector<double>> re(FftPlan::kBatch, std::vector<double>(bins, -7.0)),
                im(FftPlan::kBatch, std::vector<double>(bins, -7.0));
            const float* x[FftPlan::kBatch];
            double* re_p[FftPlan::kBatch];
            double* im_p[FftPlan::kBatch];
            for (std::size_t b = 0; b < FftPlan::kBatch; ++b) {
                x[b] = b < count ? signals[b].data() : nullptr;
                re_p[b] = re[b].data();
                im_p[b] = im[b].data();
            }
            plan.forward_batch(x, re_p, im_p, count);
            for (std::size_t b = 0; b < FftPlan::kBatch; ++b) {
                if (b >= count) {
                    EXPECT_EQ(re[b][0], -7.0) << n << " lane " << b << " written";
                    continue;
                }
                const std::vector<double> xd(signals[b].begin(), signals[b].end());
                std::vector<Complex> one(bins);
                plan.forward(xd.data(), one.data());
                double scale = 1.0;
                for (const Complex& c : one) scale = std::max(scale, std::abs(c));
                for (std::size_t k = 0; k < bins; ++k) {
                    EXPECT_NEAR(re[b][k], one[k].real(), 1e-14 * scale) << n << " " << count << " " << b << " " << k;
                    EXPECT_NEAR(im[b][k], one[k].imag(), 1e-14 * scale) << n << " " << count << " " << b << " " << k;
                }
            }
        }
    }
    const RealFftPlan plan(8);
    const float* x[FftPlan::kBatch + 1] = {};
    double* p[FftPlan::kBatch + 1] = {};
    EXPECT_THROW(plan.forward_batch(x, p, p, FftPlan::kBatch + 1), InputError);
}

// The batched real inverse (one spectrum per vector lane) against inverse() of each spectrum,
// for every length from 1 to 4096 and 1, 3, 4, 5 and 8 spectra (four lanes up to four spectra,
// eight above; the imaginary parts of bins 0 and n/2, which inverse() ignores, random too); the
// spectra are left as they were.
TEST(Fft, RealInverseBatchMatchesOneByOne) {
    std::mt19937 rng(29);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (std::size_t n = 1; n <= 4096; n *= 2) {
        const RealFftPlan plan(n);
        const std::size_t bins = plan.spectrum_size();
        for (std::size_t count : {std::size_t(1), std::size_t(3), std::size_t(4), std::size_t(5), FftPlan::kBatch}) {
            std::vector<std::vector<Complex>> spectra(count, std::vector<Complex>(bins));
            for (auto& s : spectra)
                for (Complex& c : s) c = {u(rng), u(rng)};
            const std::vector<std::vector<Complex>> kept = spectra;
            std::vector<std::vector<double>> x(count, std::vector<double>(n, -7.0));
            const Complex* in[FftPlan::kBatch];
            double* out[FftPlan::kBatch];
            for (std::size_t b = 0; b < count; ++b) {
                in[b] = spectra[b].data();
                out[b] = x[b].data();
            }
            plan.inverse_batch(in, out, count);
            for (std::size_t b = 0; b < count; ++b) {
                EXPECT_EQ(spectra[b], kept[b]) << n << " spectrum " << b << " changed";
                std::vector<Complex> work = spectra[b];
                std::vector<double> one(n);
                plan.inverse(work.data(), one.data());
                double scale = 1.0;
                for (double v : one) scale = std::max(scale, std::abs(v));
                for (std::size_t j = 0; j < n; ++j)
                    EXPECT_NEAR(x[b][j], one[j], 1e-14 * scale) << n << " " << count << " " << b << " " << j;
            }
        }
    }
    const RealFftPlan plan(8);
    const Complex* in[FftPlan::kBatch + 1] = {};
    double* out[FftPlan::kBatch + 1] = {};
    EXPECT_THROW(plan.inverse_batch(in, out, FftPlan::kBatch + 1), InputError);
}

TEST(Fft, PureToneLandsInOneBin) {
    // cos(2 pi 5 j / 64): X_5 = X_59 = 32 and every other bin 0, to rounding.
    const std::size_t n = 64;
    std::vector<double> x(n);
    for (std::size_t j = 0; j < n; ++j) x[j] = std::cos(2 * std::numbers::pi * 5.0 * double(j) / double(n));
    const RealFftPlan plan(n);
    std::vector<Complex> spectrum(plan.spectrum_size());
    plan.forward(x.data(), spectrum.data());
    for (std::size_t k = 0; k < spectrum.size(); ++k)
        EXPECT_NEAR(std::abs(spectrum[k] - Complex(k == 5 ? 32.0 : 0.0, 0.0)), 0.0, 1e-13) << "bin " << k;
}

TEST(Fft, RejectsOtherLengths) {
    for (std::size_t n : {std::size_t(0), std::size_t(3), std::size_t(12), std::size_t(1000)}) {
        EXPECT_FALSE(is_fft_length(n));
        EXPECT_THROW(FftPlan{n}, InputError) << n;
        EXPECT_THROW(RealFftPlan{n}, InputError) << n;
    }
    EXPECT_THROW(FftPlan{FftPlan::kMaxLength * 2}, InputError);
    EXPECT_TRUE(is_fft_length(1));
    EXPECT_TRUE(is_fft_length(4096));
}

}  // namespace
}  // namespace glint::convolution
