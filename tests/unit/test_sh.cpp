// Spherical harmonics: basis, recurrences, quadratures, Phong kernel, projection and reconstruction.
#include "appliance/convolution/sh.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/hdr_image.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::convolution {
namespace {

std::size_t idx(int l, int m) { return std::size_t(l * (l + 1) + m); }

HdrImage random_image(int width, int height, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    HdrImage img(width, height);
    for (float& v : img.data()) v = u(rng);
    return img;
}

double max_abs(const std::vector<double>& v) {
    double m = 0;
    for (double x : v) m = std::max(m, std::abs(x));
    return m;
}

// Brute-force projection with sh_basis at every texel: c_i = sum_texels w_row L Y_i.
ShCoefficients direct_projection(const HdrImage& img, int order, ShQuadrature q) {
    const int w = img.width(), h = img.height();
    const std::vector<double> weights = sh_row_weights(w, h, q);
    const ShLegendre legendre(order);
    ShCoefficients c;
    c.order = order;
    c.rgb.assign(std::size_t(order * order * 3), 0.0);
    std::vector<double> y(std::size_t(order * order));
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            sh_basis(legendre, texel_direction(i, j, w, h), y.data());
            const Rgb l = img.at(i, j);
            const double wl[3] = {weights[std::size_t(j)] * l.r, weights[std::size_t(j)] * l.g,
                                  weights[std::size_t(j)] * l.b};
            for (std::size_t k = 0; k < y.size(); ++k)
                for (std::size_t ch = 0; ch < 3; ++ch) c.rgb[3 * k + ch] += wl[ch] * y[k];
        }
    return c;
}

// sum_i kernel[l] c_i Y_i(d), one channel.
double evaluate_at(const ShCoefficients& c, const std::vector<double>& kernel, const glm::dvec3& d, int channel) {
    std::vector<double> y(std::size_t(c.order * c.order));
    sh_basis(c.order, d, y.data());
    double e = 0;
    for (int l = 0; l < c.order; ++l)
        for (int m = -l; m <= l; ++m) e += kernel[std::size_t(l)] * c.at(l, m, channel) * y[idx(l, m)];
    return e;
}

// Gauss-Legendre nodes and weights on [0, 1] in long double (Newton's method on P_N).
void gauss_legendre01(int n, std::vector<long double>& x, std::vector<long double>& w) {
    const long double pi = 3.141592653589793238462643383279502884L;
    x.assign(std::size_t(n), 0.0L);
    w.assign(std::size_t(n), 0.0L);
    for (int i = 0; i < n; ++i) {
        long double z = std::cos(pi * (i + 0.75L) / (n + 0.5L));
        long double dp = 1;
        for (int it = 0; it < 100; ++it) {
            long double p0 = 1, p1 = z;
            for (int k = 2; k <= n; ++k) {
                const long double p2 = ((2.0L * k - 1) * z * p1 - (k - 1.0L) * p0) / k;
                p0 = p1;
                p1 = p2;
            }
            dp = n * (z * p1 - p0) / (z * z - 1);
            const long double dz = p1 / dp;
            z -= dz;
            if (std::abs(dz) < 1e-19L) break;
        }
        x[std::size_t(i)] = (1 - z) / 2;
        w[std::size_t(i)] = 1 / ((1 - z * z) * dp * dp);  // 2 / ((1 - z^2) P'^2), halved for [0, 1]
    }
}

long double legendre_p(int l, long double x) {
    long double p0 = 1, p1 = x;
    if (l == 0) return p0;
    for (int k = 2; k <= l; ++k) {
        const long double p2 = ((2.0L * k - 1) * x * p1 - (k - 1.0L) * p0) / k;
        p0 = p1;
        p1 = p2;
    }
    return p1;
}

TEST(ShBasis, MatchesCartesianFormsOfLowBands) {
    const double pi = kPi;
    const glm::dvec3 d0{0.3, -0.5, 0.2};
    const double r = std::sqrt(glm::dot(d0, d0));
    const glm::dvec3 d{d0.x / r, d0.y / r, d0.z / r};
    std::vector<double> y(9);
    sh_basis(3, d0, y.data());  // not normalised on purpose
    const double c1 = std::sqrt(3 / (4 * pi));
    EXPECT_NEAR(y[idx(0, 0)], 0.5 / std::sqrt(pi), 1e-15);
    EXPECT_NEAR(y[idx(1, -1)], c1 * d.x, 1e-15);
    EXPECT_NEAR(y[idx(1, 0)], c1 * d.y, 1e-15);
    EXPECT_NEAR(y[idx(1, 1)], -c1 * d.z, 1e-15);
    const double c2 = std::sqrt(15 / (4 * pi));
    EXPECT_NEAR(y[idx(2, -2)], -c2 * d.x * d.z, 1e-15);
    EXPECT_NEAR(y[idx(2, -1)], c2 * d.x * d.y, 1e-15);
    EXPECT_NEAR(y[idx(2, 0)], std::sqrt(5 / (16 * pi)) * (3 * d.y * d.y - 1), 1e-15);
    EXPECT_NEAR(y[idx(2, 1)], -c2 * d.y * d.z, 1e-15);
    EXPECT_NEAR(y[idx(2, 2)], std::sqrt(15 / (16 * pi)) * (d.z * d.z - d.x * d.x), 1e-15);
}

TEST(ShLegendre, MatchesStdSphLegendre) {
    // std::sph_legendre(l, m, theta) = (-1)^m \bar P_lm(cos theta) (it carries the Condon-Shortley phase).
    const int order = 120;
    const ShLegendre legendre(order);
    std::vector<double> p(std::size_t(order * (order + 1) / 2));
    for (double theta : {0.013, 0.4, 1.1, kPi / 2, 2.2, 3.1}) {
        legendre.evaluate(std::cos(theta), std::sin(theta), p.data());
        double worst = 0;
        for (int l = 0; l < order; ++l)
            for (int m = 0; m <= l; ++m) {
                const double ref = (m % 2 ? -1.0 : 1.0) *
                                   std::sph_legendre(unsigned(l), unsigned(m), theta);
                worst = std::max(worst, std::abs(p[std::size_t(legendre_index(l, m))] - ref));
            }
        EXPECT_LT(worst, 1e-12) << "theta " << theta;
    }
}

TEST(ShLegendre, AdditionTheoremHoldsToOrder512) {
    // sum_m Y_lm(d)^2 = (2l+1)/(4 pi) for every direction: checks every \bar P_lm at once. s is taken from x
    // so that x^2 + s^2 = 1 to rounding: near a pole x = cos(theta) fixes theta only to eps/theta, and
    // sin(theta) rounded on its own would describe another direction by that much (|dY| ~ l eps/theta).
    const int order = 512;
    const ShLegendre legendre(order);
    std::vector<double> p(std::size_t(order * (order + 1) / 2));
    for (double theta : {kPi / 2048, 0.01, 0.3, 1.0, kPi / 2, 2.5, kPi - 1e-3}) {
        const double x = std::cos(theta);
        legendre.evaluate(x, std::sqrt((1 - x) * (1 + x)), p.data());
        double worst = 0;
        for (int l = 0; l < order; ++l) {
            double s = 0;
            for (int m = 0; m <= l; ++m) {
                const double v = p[std::size_t(legendre_index(l, m))];
                s += (m == 0 ? 1.0 : 2.0) * v * v;
            }
            const double want = (2.0 * l + 1) / (4 * kPi);
            worst = std::max(worst, std::abs(s - want) / want);
        }
        // The recurrences' rounding, worst near the pole: 8.98e-13 at theta = pi/2048 where FMA
        // fuses the multiply-adds (-march=native on an FMA CPU), 1.12e-12 with each rounded
        // apart (the portable x86-64 build, GLINT_NATIVE=OFF). 2e-12 (~9000 ulp over 512 bands)
        // holds both; a wrong coefficient is off by far more than that.
        EXPECT_LT(worst, 2e-12) << "theta " << theta;
    }
}

TEST(ShLegendre, FlushAtThePoleMatchesExtendedRange) {
    // Near the pole sin^m underflows; long double (exponent range to 1e-4951) does not. The values flushed
    // to 0 must be negligible (below 1e-100), and the rest agree to 1e-12 of the band's scale
    // sqrt((2l+1)/(4 pi)). Both get the same x and s in double.
    const int order = 512;
    const ShLegendre legendre(order);
    std::vector<double> p(std::size_t(order * (order + 1) / 2));
    for (double theta : {kPi / 2048, 0.02, kPi - kPi / 1024}) {
        const long double x = std::cos(theta);
        const long double s = std::sin(theta);
        legendre.evaluate(double(x), double(s), p.data());
        long double pmm = 0.5L / std::sqrt(3.141592653589793238462643383279502884L);
        double worst = 0, largest_flushed = 0;
        int flushed = 0;
        for (int m = 0; m < order; ++m) {
            if (m > 0) pmm *= std::sqrt((2.0L * m + 1) / (2.0L * m)) * s;
            long double a = pmm, b = std::sqrt(2.0L * m + 3) * x * pmm;  // l = m, m + 1
            for (int l = m; l < order; ++l) {
                long double v = a;
                if (l == m + 1) v = b;
                if (l >= m + 2) {
                    const long double al = std::sqrt((4.0L * l * l - 1) / (1.0L * l * l - 1.0L * m * m));
                    const long double bl = std::sqrt(((l - 1.0L) * (l - 1) - 1.0L * m * m) /
                                                     (4.0L * (l - 1) * (l - 1) - 1));
                    v = al * (x * b - bl * a);
                    a = b;
                    b = v;
                }
                const double got = p[std::size_t(legendre_index(l, m))];
                if (got == 0.0 && v != 0.0L) {
                    ++flushed;
                    largest_flushed = std::max(largest_flushed, double(std::abs(v)));
                } else {
                    const double scale = std::sqrt((2.0 * l + 1) / (4 * kPi));
                    worst = std::max(worst, double(std::abs(static_cast<long double>(got) - v)) / scale);
                }
            }
        }
        EXPECT_LT(worst, 1e-12) << "theta " << theta;
        EXPECT_LT(largest_flushed, 1e-100) << "theta " << theta;
        if (theta < 0.01) {
            EXPECT_GT(flushed, 0) << "the pole rows exercise the flush";
        }
    }
}

TEST(ShQuadrature, FejerWeightsIntegratePolynomials) {
    for (int h : {7, 32, 33, 128}) {
        const std::vector<double> w = fejer_weights(h);
        for (int k = 0; k < h; ++k) {
            double s = 0;
            for (int j = 0; j < h; ++j) s += w[std::size_t(j)] * std::pow(std::cos(row_theta(j, h)), k);
            const double want = k % 2 ? 0.0 : 2.0 / (k + 1);
            EXPECT_NEAR(s, want, 1e-14) << "H " << h << " degree " << k;
        }
        for (double v : w) EXPECT_GT(v, 0.0);
    }
}

TEST(ShBasis, OrthonormalOnFejerGrid) {
    // sum over a 512x256 grid of Y_a Y_b dOmega (Fejer weights) = delta_ab for order 16: the products have
    // band < 32 < H/2 and azimuthal degree < W, so the rule is exact.
    const int order = 16, n = order * order, w = 512, h = 256;
    const std::vector<double> weights = sh_row_weights(w, h, ShQuadrature::Fejer);
    const ShLegendre legendre(order);
    constexpr int kBlock = 8;  // rank-8 updates of the Gram matrix
    const int chunks = 2;
    std::vector<std::vector<double>> gram(chunks, std::vector<double>(std::size_t(n * n), 0.0));
    parallel_for(chunks, chunks, [&](int chunk) {
        std::vector<double>& g = gram[std::size_t(chunk)];
        std::vector<double> y(std::size_t(kBlock * n)), wy(std::size_t(kBlock * n));
        for (int j = chunk; j < h; j += chunks)
            for (int i0 = 0; i0 < w; i0 += kBlock) {
                for (int t = 0; t < kBlock; ++t) {
                    double* yt = y.data() + std::size_t(t * n);
                    sh_basis(legendre, texel_direction(i0 + t, j, w, h), yt);
                    for (int a = 0; a < n; ++a) wy[std::size_t(t * n + a)] = weights[std::size_t(j)] * yt[a];
                }
                for (int a = 0; a < n; ++a) {
                    double* ga = g.data() + std::size_t(a * n);
                    for (int t = 0; t < kBlock; ++t) {
                        const double wa = wy[std::size_t(t * n + a)];
                        const double* yt = y.data() + std::size_t(t * n);
                        for (int b = a; b < n; ++b) ga[b] += wa * yt[b];
                    }
                }
            }
    });
    double worst = 0;
    for (int a = 0; a < n; ++a)
        for (int b = a; b < n; ++b) {
            const double s = gram[0][std::size_t(a * n + b)] + gram[1][std::size_t(a * n + b)];
            worst = std::max(worst, std::abs(s - (a == b ? 1.0 : 0.0)));
        }
    EXPECT_LT(worst, 1e-10);
}

TEST(ShProject, SeparablePathMatchesBasis) {
    // Even and odd widths (an odd width has a column at phi = 0); 32 takes the FFT (order 12 is enough).
    for (int w : {48, 45, 32}) {
        const HdrImage img = random_image(w, 24, 7u + unsigned(w));
        for (ShQuadrature q : {ShQuadrature::TexelSolidAngle, ShQuadrature::Fejer}) {
            const ShCoefficients fast = sh_project(img, 12, 2, q);
            const ShCoefficients slow = direct_projection(img, 12, q);
            ASSERT_EQ(fast.rgb.size(), slow.rgb.size());
            double worst = 0;
            for (std::size_t k = 0; k < fast.rgb.size(); ++k)
                worst = std::max(worst, std::abs(fast.rgb[k] - slow.rgb[k]));
            EXPECT_LT(worst, 1e-12 * max_abs(slow.rgb)) << "width " << w;
        }
    }
}

std::vector<double> random_values(std::size_t count, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    std::vector<double> v(count);
    for (double& x : v) x = u(rng);
    return v;
}

ShCoefficients random_coefficients(int order, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    ShCoefficients c;
    c.order = order;
    c.rgb.resize(std::size_t(order * order * 3));
    for (int l = 0; l < order; ++l)
        for (int m = -l; m <= l; ++m)
            for (int ch = 0; ch < 3; ++ch) c.at(l, m, ch) = u(rng) / (1.0 + 0.1 * l);
    return c;
}

// Largest |a - b| relative to the largest |b|.
double relative_difference(const std::vector<double>& a, const std::vector<double>& b) {
    double worst = 0;
    for (std::size_t k = 0; k < b.size(); ++k) worst = std::max(worst, std::abs(a[k] - b[k]));
    return worst / max_abs(b);
}

TEST(ShProject, FftPathMatchesDirectSums) {
    // 256x128 at order 64, and the aliased cases: order W/2 < 64 <= W and order > W, where the FFT path
    // reads X_(m mod W) by conjugate symmetry.
    for (auto [w, h, order] : {std::tuple{256, 128, 64}, std::tuple{64, 32, 64}, std::tuple{32, 16, 40},
                               std::tuple{2, 4, 5}, std::tuple{1, 3, 4}}) {
        const std::vector<double> map = random_values(std::size_t(w * h * 3), 31u + unsigned(w));
        for (ShQuadrature q : {ShQuadrature::TexelSolidAngle, ShQuadrature::Fejer}) {
            const ShCoefficients fft = detail::sh_project(map, w, h, order, 2, q, ShAzimuthal::Fft);
            const ShCoefficients direct = detail::sh_project(map, w, h, order, 2, q, ShAzimuthal::Direct);
            ASSERT_EQ(fft.rgb.size(), direct.rgb.size());
            EXPECT_LT(relative_difference(fft.rgb, direct.rgb), 1e-12) << w << "x" << h << " order " << order;
        }
    }
}

TEST(ShReconstruct, FftPathMatchesDirectSums) {
    // 128x64 at order 64 (order = W/2), and widths below the order, where the FFT path folds frequency m
    // onto m mod W and W - (m mod W).
    const ShCoefficients c = random_coefficients(64, 17u);
    const std::vector<double> kernel = phong_sh_kernel(4.0, 64);
    for (auto [w, h] : {std::pair{128, 64}, std::pair{64, 32}, std::pair{32, 16}, std::pair{16, 8},
                        std::pair{2, 4}, std::pair{1, 3}}) {
        const std::vector<double> fft = detail::sh_evaluate(c, kernel, w, h, 2, ShAzimuthal::Fft);
        const std::vector<double> direct = detail::sh_evaluate(c, kernel, w, h, 2, ShAzimuthal::Direct);
        ASSERT_EQ(fft.size(), direct.size());
        EXPECT_LT(relative_difference(fft, direct), 1e-12) << w << "x" << h;
    }
}

TEST(ShAzimuthal, AutomaticTakesTheFftForPowerOfTwoWidthsAndHighOrders) {
    // The FFT from 12 bands in the projection and 24 in the synthesis; widths that are not powers of two
    // always keep the direct sums, and forcing the FFT on them is an error.
    const ShQuadrature q = ShQuadrature::TexelSolidAngle;
    auto project = [&](const std::vector<double>& map, int w, int h, int order, ShAzimuthal a) {
        return detail::sh_project(map, w, h, order, 2, q, a).rgb;
    };
    const std::vector<double> map = random_values(std::size_t(64 * 32 * 3), 5u);
    EXPECT_EQ(sh_project(map, 64, 32, 12, 2).rgb, project(map, 64, 32, 12, ShAzimuthal::Fft));
    EXPECT_EQ(sh_project(map, 64, 32, 11, 2).rgb, project(map, 64, 32, 11, ShAzimuthal::Direct));
    const std::vector<double> odd_map = random_values(std::size_t(45 * 24 * 3), 9u);
    EXPECT_EQ(sh_project(odd_map, 45, 24, 30, 2).rgb, project(odd_map, 45, 24, 30, ShAzimuthal::Direct));
    EXPECT_THROW(project(odd_map, 45, 24, 30, ShAzimuthal::Fft), InputError);

    const ShCoefficients c = random_coefficients(24, 3u);
    const ShCoefficients low = random_coefficients(23, 4u);
    const std::vector<double> k(24, 1.0);
    EXPECT_EQ(sh_evaluate(c, k, 64, 32, 2), detail::sh_evaluate(c, k, 64, 32, 2, ShAzimuthal::Fft));
    EXPECT_EQ(sh_evaluate(low, k, 64, 32, 2), detail::sh_evaluate(low, k, 64, 32, 2, ShAzimuthal::Direct));
    EXPECT_EQ(sh_evaluate(c, k, 50, 25, 2), detail::sh_evaluate(c, k, 50, 25, 2, ShAzimuthal::Direct));
    EXPECT_THROW(detail::sh_evaluate(c, k, 50, 25, 2, ShAzimuthal::Fft), InputError);
}

// Straightforward separable references for the paired-row paths of sh_project and sh_evaluate: row by
// row in long double, every row with its own x = cos(theta) (no mirror pairs, no blocks of rows), the
// Legendre values from ShLegendre::evaluate and the azimuthal sums over the columns with cos(m phi_i) and
// sin(m phi_i) directly (no FFT).
struct ReferenceAzimuths {
    int width;
    std::vector<long double> cosines, sines;  // [m * width + i]

    ReferenceAzimuths(int order, int w) : width(w) {
        const long double pi = 3.141592653589793238462643383279502884L;
        for (int m = 0; m < order; ++m)
            for (int i = 0; i < w; ++i) {
                const long double phi = 2 * pi * (i + 0.5L) / w - pi;
                cosines.push_back(std::cos(m * phi));
                sines.push_back(std::sin(m * phi));
            }
    }
    long double c(int m, int i) const { return cosines[std::size_t(m * width + i)]; }
    long double s(int m, int i) const { return sines[std::size_t(m * width + i)]; }
};

std::vector<double> reference_projection(const std::vector<double>& map, int w, int h, int order,
                                         ShQuadrature q) {
    const std::vector<double> weights = sh_row_weights(w, h, q);
    const ShLegendre legendre(order);
    const ReferenceAzimuths az(order, w);
    std::vector<long double> c(std::size_t(order * order * 3), 0.0L);
    std::vector<double> p(std::size_t(order * (order + 1) / 2));
    std::vector<long double> f(std::size_t(order * 3)), g(std::size_t(order * 3));
    for (int j = 0; j < h; ++j) {
        const double theta = row_theta(j, h);
        legendre.evaluate(std::cos(theta), std::sin(theta), p.data());
        for (int m = 0; m < order; ++m)
            for (int ch = 0; ch < 3; ++ch) {
                long double fs = 0, gs = 0;
                for (int i = 0; i < w; ++i) {
                    const long double v = map[std::size_t((j * w + i) * 3 + ch)];
                    fs += v * az.c(m, i);
                    gs += v * az.s(m, i);
                }
                f[std::size_t(m * 3 + ch)] = fs;
                g[std::size_t(m * 3 + ch)] = gs;
            }
        for (int l = 0; l < order; ++l)
            for (int m = 0; m <= l; ++m) {
                const long double y = weights[std::size_t(j)] * (m == 0 ? 1.0L : std::sqrt(2.0L)) *
                                      p[std::size_t(legendre_index(l, m))];
                for (int ch = 0; ch < 3; ++ch) {
                    c[idx(l, m) * 3 + std::size_t(ch)] += y * f[std::size_t(m * 3 + ch)];
                    if (m > 0) c[idx(l, -m) * 3 + std::size_t(ch)] += y * g[std::size_t(m * 3 + ch)];
                }
            }
    }
    return std::vector<double>(c.begin(), c.end());
}

std::vector<double> reference_evaluation(const ShCoefficients& c, const std::vector<double>& kernel, int w,
                                         int h) {
    const int order = c.order;
    const ShLegendre legendre(order);
    const ReferenceAzimuths az(order, w);
    std::vector<double> out(std::size_t(w * h * 3));
    std::vector<double> p(std::size_t(order * (order + 1) / 2));
    std::vector<long double> hs(std::size_t(order * 3)), ks(std::size_t(order * 3));
    for (int j = 0; j < h; ++j) {
        const double theta = row_theta(j, h);
        legendre.evaluate(std::cos(theta), std::sin(theta), p.data());
        std::fill(hs.begin(), hs.end(), 0.0L);
        std::fill(ks.begin(), ks.end(), 0.0L);
        for (int l = 0; l < order; ++l)
            for (int m = 0; m <= l; ++m) {
                const long double y = kernel[std::size_t(l)] * (m == 0 ? 1.0L : std::sqrt(2.0L)) *
                                      p[std::size_t(legendre_index(l, m))];
                for (int ch = 0; ch < 3; ++ch) {
                    hs[std::size_t(m * 3 + ch)] += y * c.at(l, m, ch);
                    if (m > 0) ks[std::size_t(m * 3 + ch)] += y * c.at(l, -m, ch);
                }
            }
        for (int i = 0; i < w; ++i)
            for (int ch = 0; ch < 3; ++ch) {
                long double e = 0;
                for (int m = 0; m < order; ++m)
                    e += hs[std::size_t(m * 3 + ch)] * az.c(m, i) + ks[std::size_t(m * 3 + ch)] * az.s(m, i);
                out[std::size_t((j * w + i) * 3 + ch)] = double(e);
            }
    }
    return out;
}

TEST(ShPairedRows, ProjectionMatchesRowByRowReference) {
    // Odd heights (a middle row without a mirror) and even ones; power-of-two widths take the FFT, 50 the
    // direct sums; order 200 on 31 to 33 rows leaves most of the degrees above the rows' resolution and
    // flushes the diagonals of the polar rows; 64 and 200 fold frequencies above W/2 on 64 columns.
    for (auto [w, h] : {std::pair{64, 31}, std::pair{64, 32}, std::pair{256, 128}, std::pair{50, 33}}) {
        const std::vector<double> map = random_values(std::size_t(w * h * 3), 41u + unsigned(w + h));
        for (int order : {16, 64, 200}) {
            const std::vector<ShQuadrature> rules =
                w == 64 ? std::vector{ShQuadrature::TexelSolidAngle, ShQuadrature::Fejer}
                        : std::vector{ShQuadrature::TexelSolidAngle};
            for (ShQuadrature q : rules) {
                const ShCoefficients got = sh_project(map, w, h, order, 2, q);
                const std::vector<double> want = reference_projection(map, w, h, order, q);
                ASSERT_EQ(got.rgb.size(), want.size());
                EXPECT_LT(relative_difference(got.rgb, want), 1e-12) << w << "x" << h << " order " << order;
            }
        }
    }
}

TEST(ShPairedRows, EvaluationMatchesRowByRowReference) {
    // As above; order 16 stays below the synthesis' FFT crossover, so 64 and 256 columns take both paths.
    for (auto [w, h] : {std::pair{64, 31}, std::pair{64, 32}, std::pair{256, 128}, std::pair{50, 33}}) {
        for (int order : {16, 64, 200}) {
            const ShCoefficients c = random_coefficients(order, 53u + unsigned(order));
            const std::vector<double> kernel = phong_sh_kernel(6.0, order);
            const std::vector<double> got = sh_evaluate(c, kernel, w, h, 2);
            const std::vector<double> want = reference_evaluation(c, kernel, w, h);
            ASSERT_EQ(got.size(), want.size());
            EXPECT_LT(relative_difference(got, want), 1e-12) << w << "x" << h << " order " << order;
        }
    }
}

TEST(ShPairedRows, SmallMapsAndOrdersMatchReference) {
    // One row (the middle row alone), two rows (one pair), three, and fewer pairs than one block of rows;
    // order 1 has no recurrence step at all.
    for (auto [w, h] : {std::pair{8, 1}, std::pair{8, 2}, std::pair{7, 3}, std::pair{16, 17}, std::pair{1, 5}}) {
        const std::vector<double> map = random_values(std::size_t(w * h * 3), 61u + unsigned(w * h));
        for (int order : {1, 2, 5, 40}) {
            const ShCoefficients got = sh_project(map, w, h, order, 2, ShQuadrature::TexelSolidAngle);
            const std::vector<double> want =
                reference_projection(map, w, h, order, ShQuadrature::TexelSolidAngle);
            EXPECT_LT(relative_difference(got.rgb, want), 1e-12) << w << "x" << h << " order " << order;
            const std::vector<double> kernel = phong_sh_kernel(2.0, order);
            const std::vector<double> e = sh_evaluate(got, kernel, w, h, 2);
            EXPECT_LT(relative_difference(e, reference_evaluation(got, kernel, w, h)), 1e-12)
                << w << "x" << h << " order " << order;
        }
    }
}

TEST(ShPairedRows, OddHeightsDoNotDependOnThreadCount) {
    for (auto [w, h] : {std::pair{64, 33}, std::pair{45, 31}}) {  // FFT and direct sums
        const std::vector<double> map = random_values(std::size_t(w * h * 3), 71u);
        const ShCoefficients one = sh_project(map, w, h, 40, 1);
        const std::vector<double> k = phong_sh_kernel(3.0, 40);
        const std::vector<double> e1 = sh_evaluate(one, k, w, h, 1);
        for (int threads : {2, 3, 5}) {
            EXPECT_EQ(sh_project(map, w, h, 40, threads).rgb, one.rgb) << threads << " threads";
            EXPECT_EQ(sh_evaluate(one, k, w, h, threads), e1) << threads << " threads";
        }
    }
}

TEST(ShReconstruct, SeparablePathMatchesBasis) {
    const HdrImage img = random_image(64, 32, 11u);
    const ShCoefficients c = sh_project(img, 20, 2);
    const std::vector<double> ones(20, 1.0);
    for (int w : {40, 41, 32, 16}) {  // 32 and 16 by FFT (forced: order 20 is below its crossover); 16 folds
        const int h = 20;
        const ShAzimuthal a = w % 16 == 0 ? ShAzimuthal::Fft : ShAzimuthal::Direct;
        const std::vector<double> e = detail::sh_evaluate(c, ones, w, h, 2, a);
        for (auto [i, j] : {std::pair{0, 0}, std::pair{7, 3}, std::pair{w / 2, 10}, std::pair{w - 1, h - 1}}) {
            const glm::dvec3 d = texel_direction(i, j, w, h);
            for (int ch = 0; ch < 3; ++ch) {
                const double want = evaluate_at(c, ones, d, ch);
                EXPECT_NEAR(e[std::size_t((j * w + i) * 3 + ch)], want, 1e-12) << i << "," << j;
            }
        }
    }
}

TEST(ShProject, BandLimitedFunctionRoundTripsAtOrder64) {
    // Bands 0..63 on a 256x128 grid: products of two such functions have band <= 126 < H and azimuthal
    // degree <= 126 < W, so Fejer's rule recovers the coefficients exactly up to rounding.
    const int order = 64, w = 256, h = 128;
    const ShCoefficients c = random_coefficients(order, 5u);
    const std::vector<double> ones(std::size_t(order), 1.0);

    // In double (sh_evaluate and the span overload): 1e-9 relative to the largest coefficient.
    const std::vector<double> f = sh_evaluate(c, ones, w, h, 2);
    const ShCoefficients back = sh_project(f, w, h, order, 2, ShQuadrature::Fejer);
    double worst = 0;
    for (std::size_t k = 0; k < c.rgb.size(); ++k) worst = std::max(worst, std::abs(back.rgb[k] - c.rgb[k]));
    EXPECT_LE(worst, 1e-9 * max_abs(c.rgb));
    const std::vector<double> f2 = sh_evaluate(back, ones, w, h, 2);
    double worst_value = 0;
    for (std::size_t k = 0; k < f.size(); ++k) worst_value = std::max(worst_value, std::abs(f2[k] - f[k]));
    EXPECT_LE(worst_value, 1e-9 * max_abs(f));

    // Through float images (sh_reconstruct, sh_project of an HdrImage): an offset in c_00 keeps the
    // function positive, so nothing is clamped; float storage limits the agreement to ~1e-7.
    double lowest = 0;
    for (double v : f) lowest = std::min(lowest, v);
    ShCoefficients shifted = c;
    for (int ch = 0; ch < 3; ++ch) shifted.at(0, 0, ch) += std::sqrt(4 * kPi) * (1.0 - lowest);
    long long clamped = -1;
    const HdrImage img = sh_reconstruct(shifted, ones, w, h, 2, &clamped);
    EXPECT_EQ(clamped, 0);
    const ShCoefficients back_f = sh_project(img, order, 2, ShQuadrature::Fejer);
    double worst_f = 0;
    for (std::size_t k = 0; k < c.rgb.size(); ++k)
        worst_f = std::max(worst_f, std::abs(back_f.rgb[k] - shifted.rgb[k]));
    EXPECT_LE(worst_f, 1e-6 * max_abs(shifted.rgb));
}

TEST(ShProject, ConstantSkyGivesOnlyL00) {
    const Rgb sky{1.0f, 2.5f, 0.25f};
    const double want[3] = {1.0, 2.5, 0.25};
    auto constant = [&](int w, int h) {
        HdrImage img(w, h);
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) img.set(i, j, sky);
        return img;
    };
    auto largest_other = [&](const ShCoefficients& c) {  // relative to L, over every channel
        double m = 0;
        for (std::size_t k = 3; k < c.rgb.size(); ++k) m = std::max(m, std::abs(c.rgb[k]) / want[k % 3]);
        return m;
    };
    // Fejer: exact (the weights sum to 2 and integrate P_l, l < H, to 0).
    const ShCoefficients f = sh_project(constant(64, 32), 16, 2, ShQuadrature::Fejer);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(f.at(0, 0, ch), std::sqrt(4 * kPi) * want[ch], 1e-13);
    EXPECT_LT(largest_other(f), 1e-12);

    // TexelSolidAngle: c_00 is exact (the row solid angles sum to 4 pi), the others are 0 only to second
    // order in the row height (a midpoint rule in theta): halving the rows quarters them, and on a
    // 2048x1024 map all of bands 1..15 are below 1e-5 L.
    const ShCoefficients t = sh_project(constant(2048, 1024), 16, 2);
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(t.at(0, 0, ch), std::sqrt(4 * kPi) * want[ch], 1e-13);
    EXPECT_LT(largest_other(t), 1e-5);
    const double coarse = largest_other(sh_project(constant(256, 128), 16, 2));
    const double fine = largest_other(sh_project(constant(512, 256), 16, 2));
    EXPECT_NEAR(coarse / fine, 4.0, 0.2);
}

TEST(ShKernel, IrradianceBands) {
    const std::vector<double> k = phong_sh_kernel(1.0, 5);
    EXPECT_DOUBLE_EQ(k[0], 1.0);
    EXPECT_DOUBLE_EQ(k[1], 2.0 / 3.0);
    EXPECT_DOUBLE_EQ(k[2], 0.25);
    EXPECT_DOUBLE_EQ(k[3], 0.0);
    EXPECT_DOUBLE_EQ(k[4], -1.0 / 24.0);
}

TEST(ShKernel, PhongMatchesQuadrature) {
    // (n+1) int_0^1 x^n P_l(x) dx with x = t^2: 2 (n+1) int_0^1 t^(2n+1) P_l(t^2) dt, a polynomial of degree
    // <= 449 for the n below, integrated exactly by 256-point Gauss-Legendre in long double.
    std::vector<long double> t, wt;
    gauss_legendre01(256, t, wt);
    const int order = 65;
    for (double n : {0.0, 0.5, 1.0, 2.0, 2.5, 10.0, 20.0, 160.0}) {
        const std::vector<double> k = phong_sh_kernel(n, order);
        for (int l = 0; l < order; ++l) {
            long double s = 0;
            for (std::size_t q = 0; q < t.size(); ++q)
                s += wt[q] * 2 * std::pow(t[q], 2.0L * n + 1) * legendre_p(l, t[q] * t[q]);
            const long double want = (n + 1) * s;
            EXPECT_NEAR(k[std::size_t(l)], double(want), 1e-9) << "n " << n << " l " << l;
            EXPECT_NEAR(k[std::size_t(l)], double(want), 1e-12 * std::abs(double(want)) + 1e-15)
                << "n " << n << " l " << l;
        }
    }
}

TEST(ShProject, ColumnRotationOnlyChangesAzimuthalPhases) {
    // Shifting the map by s columns turns it by delta = 2 pi s / W about +Y: L'(phi) = L(phi - delta), so
    //   c'_lm = cos(m delta) c_lm - sin(m delta) c_l,-m,   c'_l,-m = sin(m delta) c_lm + cos(m delta) c_l,-m
    // and the power c_lm^2 + c_l,-m^2 of each (l, |m|) is unchanged.
    const int w = 64, h = 32, s = 5, order = 16;
    const HdrImage img = random_image(w, h, 3u);
    HdrImage turned(w, h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) turned.set((i + s) % w, j, img.at(i, j));
    const ShCoefficients a = sh_project(img, order, 2);
    const ShCoefficients b = sh_project(turned, order, 2);
    const double delta = kTwoPi * s / w;
    const double scale = max_abs(a.rgb);
    for (int l = 0; l < order; ++l)
        for (int ch = 0; ch < 3; ++ch) {
            EXPECT_NEAR(b.at(l, 0, ch), a.at(l, 0, ch), 1e-13 * scale);
            for (int m = 1; m <= l; ++m) {
                const double pa = a.at(l, m, ch) * a.at(l, m, ch) + a.at(l, -m, ch) * a.at(l, -m, ch);
                const double pb = b.at(l, m, ch) * b.at(l, m, ch) + b.at(l, -m, ch) * b.at(l, -m, ch);
                EXPECT_NEAR(pb, pa, 1e-10 * pa + 1e-14 * scale * scale) << l << "," << m;
                const double cm = std::cos(m * delta), sm = std::sin(m * delta);
                EXPECT_NEAR(b.at(l, m, ch), cm * a.at(l, m, ch) - sm * a.at(l, -m, ch), 1e-13 * scale);
                EXPECT_NEAR(b.at(l, -m, ch), sm * a.at(l, m, ch) + cm * a.at(l, -m, ch), 1e-13 * scale);
            }
        }
}

TEST(ShProject, ResultDoesNotDependOnThreadCount) {
    for (int w : {96, 64}) {  // direct sums and FFT
        const HdrImage img = random_image(w, 48, 21u);
        const ShCoefficients one = sh_project(img, 24, 1);
        for (int threads : {2, 3, 7}) {
            const ShCoefficients many = sh_project(img, 24, threads);
            EXPECT_EQ(many.rgb, one.rgb) << threads << " threads";
        }
        const std::vector<double> k = phong_sh_kernel(8.0, 24);
        for (int out_w : {50, 64}) {
            const HdrImage r1 = sh_reconstruct(one, k, out_w, 25, 1);
            const HdrImage r3 = sh_reconstruct(one, k, out_w, 25, 3);
            EXPECT_EQ(r1.data(), r3.data());
        }
    }
}

TEST(ShConvolution, BrightSpotMatchesDirectSum) {
    // A small bright spot on a dim sky, order 128, n = 20, against the normalised direct sum of the
    // conventions. The SH result uses the continuous normalisation 2 pi / (n+1); the direct denominator,
    // sum_k max(0, r.w_k)^n dOmega_k, is smaller by about h^2/24 = 4e-4 (h = pi/32, the midpoint rule in
    // theta with exact row solid angles), which is the error seen here.
    const int w = 64, h = 32, order = 128;
    const double n = 20;
    HdrImage img(w, h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) img.set(i, j, {0.01f, 0.02f, 0.01f});
    img.set(20, 10, {100, 50, 10});
    img.set(21, 10, {100, 50, 10});
    img.set(20, 11, {80, 40, 8});
    const ShCoefficients c = sh_project(img, order, 2);
    const std::vector<double> k = phong_sh_kernel(n, order);
    const double theta0 = row_theta(10, h), phi0 = column_phi(20, w);
    for (auto [dt, dp] : {std::pair{0.0, 0.0}, std::pair{0.1, 0.05}, std::pair{-0.2, 0.1}, std::pair{0.3, -0.3},
                          std::pair{0.6, 0.4}, std::pair{1.5, 2.0}}) {
        const glm::dvec3 r = direction_from_angles(theta0 + dt, phi0 + dp);
        double num[3] = {0, 0, 0}, den = 0;
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) {
                const double cosine = glm::dot(r, texel_direction(i, j, w, h));
                if (cosine <= 0) continue;
                const double f = std::pow(cosine, n) * row_solid_angle(j, w, h);
                const Rgb l = img.at(i, j);
                num[0] += f * l.r;
                num[1] += f * l.g;
                num[2] += f * l.b;
                den += f;
            }
        for (int ch = 0; ch < 3; ++ch) {
            const double direct = num[ch] / den;
            const double sh = evaluate_at(c, k, r, ch);
            EXPECT_LT(std::abs(sh - direct) / direct, 1e-3) << dt << "," << dp << " channel " << ch;
        }
    }
}

TEST(ShReconstruct, Order128IsFiniteAndCountsClampedValues) {
    // One bright texel is far from band-limited: its order-128 series rings below zero.
    HdrImage img(128, 64);
    img.set(40, 20, {1000, 500, 100});
    const ShCoefficients c = sh_project(img, 128, 2);
    for (double v : c.rgb) ASSERT_TRUE(std::isfinite(v));
    const std::vector<double> ones(128, 1.0);
    long long clamped = -1;
    const HdrImage out = sh_reconstruct(c, ones, 256, 128, 2, &clamped);
    for (float v : out.data()) {
        ASSERT_TRUE(std::isfinite(v));
        ASSERT_GE(v, 0.0f);
    }
    const std::vector<double> raw = sh_evaluate(c, ones, 256, 128, 2);
    long long negatives = 0;
    for (double v : raw) negatives += v < 0 ? 1 : 0;
    EXPECT_GT(negatives, 0);
    EXPECT_EQ(clamped, negatives);
}

TEST(ShErrors, RejectsUnusableInput) {
    const HdrImage img = random_image(8, 4, 1u);
    EXPECT_THROW(sh_project(HdrImage(), 4, 1), InputError);
    EXPECT_THROW(sh_project(img, 0, 1), InputError);
    EXPECT_THROW(sh_project(img, kMaxShOrder + 1, 1), InputError);
    EXPECT_THROW(phong_sh_kernel(-1.0, 4), InputError);
    EXPECT_THROW(phong_sh_kernel(std::nan(""), 4), InputError);
    EXPECT_THROW(phong_sh_kernel(1.0, 0), InputError);
    EXPECT_EQ(phong_sh_kernel(1.0, kMaxShOrder + 1).size(), std::size_t(kMaxShOrder + 1));
    const ShCoefficients c = sh_project(img, 4, 1);
    EXPECT_THROW(sh_evaluate(c, std::vector<double>(3, 1.0), 8, 4, 1), InputError);
    EXPECT_THROW(sh_reconstruct(c, std::vector<double>(4, 1.0), 0, 4, 1), InputError);
    std::vector<double> y(16);
    EXPECT_THROW(sh_basis(4, glm::dvec3{0, 0, 0}, y.data()), InputError);
    const std::vector<double> wrong(7, 0.0);
    EXPECT_THROW(sh_project(wrong, 2, 2, 2, 1), InputError);
}

}  // namespace
}  // namespace glint::convolution
