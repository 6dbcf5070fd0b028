// Spherical harmonics: stable Legendre recurrences, separable projection and reconstruction (azimuthal sums
// by FFT or directly), Phong kernel.
#include "appliance/convolution/sh.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <optional>
#include <string>

#include "appliance/convolution/fft.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::convolution {

namespace {

constexpr double kSqrt2 = std::numbers::sqrt2;

void check_order(int order) {
    if (order < 1 || order > kMaxShOrder)
        throw InputError("spherical-harmonics order " + std::to_string(order) + " is outside [1, " +
                         std::to_string(kMaxShOrder) + "]");
}

void check_size(int width, int height, const char* what) {
    if (width < 1 || height < 1)
        throw InputError(std::string(what) + " map size " + std::to_string(width) + "x" +
                         std::to_string(height) + " is empty");
}

int resolve_threads(int threads) { return threads > 0 ? threads : hardware_threads(); }

// Neumaier's compensated summation: sum + comp carries the rounding error of every addition.
inline void neumaier_add(double& sum, double& comp, double v) {
    const double t = sum + v;
    comp += std::abs(sum) >= std::abs(v) ? (sum - t) + v : (v - t) + sum;
    sum = t;
}

// cos and sin of m * phi_i for the column centres phi_i = pi (2i + 1 - W) / W, with the argument
// reduced exactly in integers: m phi_i = pi N / W, N = m (2i + 1 - W) mod 2W.
void column_angle(int m, int i, int width, double& c, double& s) {
    const long long period = 2LL * width;
    long long n = (static_cast<long long>(m) * (2LL * i + 1 - width)) % period;
    if (n < 0) n += period;
    const double angle = kPi * static_cast<double>(n) / static_cast<double>(width);
    c = std::cos(angle);
    s = std::sin(angle);
}

// Columns i and W-1-i have azimuths phi and -phi: cos(m phi) is shared and sin(m phi) changes sign, so
// both paths work on the half = W/2 column pairs; for odd W the middle column has phi = 0 exactly.
struct AzimuthTable {
    std::vector<double> cosines, sines;  // by_m: index [m * (W/2) + i]; otherwise [i * order + m]

    AzimuthTable(int width, int order, bool by_m) {
        const std::size_t half = std::size_t(width / 2), n = std::size_t(order);
        cosines.resize(half * n);
        sines.resize(half * n);
        for (std::size_t i = 0; i < half; ++i)
            for (std::size_t m = 0; m < n; ++m) {
                const std::size_t k = by_m ? m * half + i : i * n + m;
                column_angle(int(m), int(i), width, cosines[k], sines[k]);
            }
    }
};

// Lowest orders at which ShAzimuthal::Automatic takes the FFT for a power-of-two width. Three real
// transforms per row cost about as much as the vectorised direct sums of this many frequencies (measured
// for W = 64 to 4096 with 1 and 2 threads: the crossover barely moves with W, as log W grows slowly); the
// synthesis also fills and folds a spectrum, so its crossover is higher. Fixed constants, not tuned at run
// time, so a given call always takes the same path.
constexpr int kFftMinOrderProject = 12;
constexpr int kFftMinOrderEvaluate = 24;

// Whether the azimuthal sums of a width-W row go through the FFT.
bool fft_path(int width, int order, int min_order, ShAzimuthal azimuthal) {
    const bool fits = is_fft_length(std::size_t(width));
    if (azimuthal == ShAzimuthal::Fft && !fits)
        throw InputError("FFT azimuthal sums need a power-of-two width, not " + std::to_string(width));
    if (azimuthal == ShAzimuthal::Automatic) return fits && order >= min_order;
    return azimuthal == ShAzimuthal::Fft;
}

// The FFT form of the azimuthal sums. With phi_i = phi_0 + 2 pi i / W,
//   sum_i L_i e^(-i m phi_i) = e^(-i m phi_0) X_(m mod W),   X = the forward DFT of the row,
// so a row's F_m - i G_m is its spectrum turned by the phase of column 0; the phases are reduced exactly
// in integers like the direct sums' angles. Where m mod W > W/2, X is read by conjugate symmetry from
// W - (m mod W), so any order works with any width.
struct FftAzimuth {
    RealFftPlan plan;
    std::vector<double> phase_cos, phase_sin;  // cos(m phi_0), sin(m phi_0) for m < order

    FftAzimuth(int width, int order) : plan(std::size_t(width)) {
        phase_cos.resize(std::size_t(order));
        phase_sin.resize(std::size_t(order));
        for (int m = 0; m < order; ++m)
            column_angle(m, 0, width, phase_cos[std::size_t(m)], phase_sin[std::size_t(m)]);
    }
};

// Polar angle of a row centre: x = cos(theta), s = sin(theta) > 0.
void row_angles(int j, int height, double& x, double& s) {
    const double theta = row_theta(j, height);
    x = std::cos(theta);
    s = std::sin(theta);
}

// The projection of rows read in double by read_row(j, out[3W]); shared by the float and double inputs.
template <typename RowSource>
ShCoefficients project_impl(int width, int height, int order, int threads, ShQuadrature q,
                            ShAzimuthal azimuthal, const RowSource& read_row) {
    check_order(order);
    check_size(width, height, "input");
    threads = resolve_threads(threads);
    const ShLegendre legendre(order);
    const bool use_fft = fft_path(width, order, kFftMinOrderProject, azimuthal);
    // Only the path taken builds its table: the direct one is O(W order) cosines.
    std::optional<AzimuthTable> table;
    std::optional<FftAzimuth> fft;
    if (use_fft)
        fft.emplace(width, order);
    else
        table.emplace(width, order, false);
    const std::vector<double> weights = sh_row_weights(width, height, q);
    const std::size_t uorder = std::size_t(order);
    const int half = width / 2;
    const bool odd = width % 2 != 0;

    // Pass 1, per row j: weighted Fourier sums over the columns, 6 arrays of length order
    //   F_c[m] = w_j s_m sum_i L_c,i cos(m phi_i),  G_c[m] = w_j s_m sum_i L_c,i sin(m phi_i)
    // (s_0 = 1, s_m = sqrt2), and the diagonal \bar P_mm(cos theta_j). The sums cost O(W log W) by FFT for a
    // power-of-two width and O(W order) directly otherwise.
    std::vector<double> fourier(std::size_t(height) * 6 * uorder);
    std::vector<double> diagonal(std::size_t(height) * uorder);
    std::vector<double> xs(static_cast<std::size_t>(height));
    parallel_for(height, threads, [&](int j) {
        std::vector<double> row(std::size_t(width) * 3);
        read_row(j, row.data());
        double* f = fourier.data() + std::size_t(j) * 6 * uorder;  // F_r F_g F_b G_r G_g G_b
        double* fr = f;
        double* fg = f + uorder;
        double* fb = f + 2 * uorder;
        double* gr = f + 3 * uorder;
        double* gg = f + 4 * uorder;
        double* gb = f + 5 * uorder;
        if (use_fft) {
            const std::size_t uwidth = std::size_t(width);
            std::vector<double> channel(uwidth);
            std::vector<std::complex<double>> spectrum(fft->plan.spectrum_size());
            for (std::size_t ch = 0; ch < 3; ++ch) {
                for (std::size_t i = 0; i < uwidth; ++i) channel[i] = row[3 * i + ch];
                fft->plan.forward(channel.data(), spectrum.data());
                double* fc = f + ch * uorder;
                double* gc = f + (ch + 3) * uorder;
                for (std::size_t m = 0; m < uorder; ++m) {
                    const std::size_t k = m % uwidth;
                    const bool mirrored = 2 * k > uwidth;  // X_k = conj X_(W-k)
                    const std::complex<double> x = spectrum[mirrored ? uwidth - k : k];
                    const double a = x.real(), b = mirrored ? -x.imag() : x.imag();
                    const double c = fft->phase_cos[m], s = fft->phase_sin[m];
                    fc[m] = c * a + s * b;  // (c - i s)(a + i b) = F - i G
                    gc[m] = s * a - c * b;
                }
            }
        } else {
            for (int i = 0; i < half; ++i) {
                const double* a = row.data() + 3 * std::size_t(i);
                const double* b = row.data() + 3 * std::size_t(width - 1 - i);
                const double s0 = a[0] + b[0], s1 = a[1] + b[1], s2 = a[2] + b[2];
                const double d0 = a[0] - b[0], d1 = a[1] - b[1], d2 = a[2] - b[2];
                const double* cm = table->cosines.data() + std::size_t(i) * uorder;
                const double* sm = table->sines.data() + std::size_t(i) * uorder;
                for (std::size_t m = 0; m < uorder; ++m) {  // independent lanes: vectorises
                    fr[m] += s0 * cm[m];
                    fg[m] += s1 * cm[m];
                    fb[m] += s2 * cm[m];
                    gr[m] += d0 * sm[m];
                    gg[m] += d1 * sm[m];
                    gb[m] += d2 * sm[m];
                }
            }
            if (odd) {  // phi = 0: cos(m phi) = 1, sin(m phi) = 0
                const double* c = row.data() + 3 * std::size_t(half);
                for (std::size_t m = 0; m < uorder; ++m) {
                    fr[m] += c[0];
                    fg[m] += c[1];
                    fb[m] += c[2];
                }
            }
        }
        const double w = weights[std::size_t(j)];
        for (std::size_t k = 0; k < 6; ++k)
            for (std::size_t m = 0; m < uorder; ++m) f[k * uorder + m] *= m == 0 ? w : w * kSqrt2;
        double x = 0, s = 0;
        row_angles(j, height, x, s);
        xs[std::size_t(j)] = x;
        legendre.diagonal(s, diagonal.data() + std::size_t(j) * uorder);
    });

    // Pass 2, per m (disjoint coefficients): c_lm = sum_j \bar P_lm(x_j) F[m], rows summed in order with
    // Neumaier sums, so the result does not depend on the thread count.
    ShCoefficients out;
    out.order = order;
    out.rgb.assign(uorder * uorder * 3, 0.0);
    parallel_for(order, threads, [&](int m) {
        const std::size_t count = uorder - std::size_t(m);
        const std::size_t lanes = m == 0 ? 3 : 6;  // cos part r g b, then sin part r g b
        std::vector<double> p(count);
        std::vector<double> sum(count * lanes, 0.0), comp(count * lanes, 0.0);
        for (int j = 0; j < height; ++j) {
            const double pmm = diagonal[std::size_t(j) * uorder + std::size_t(m)];
            if (pmm == 0.0) continue;  // underflowed at the pole: the whole column is 0
            legendre.column(m, xs[std::size_t(j)], pmm, p.data());
            const double* f = fourier.data() + std::size_t(j) * 6 * uorder + std::size_t(m);
            double v[6];
            for (std::size_t k = 0; k < lanes; ++k) v[k] = f[k * uorder];
            for (std::size_t t = 0; t < count; ++t)
                for (std::size_t k = 0; k < lanes; ++k)
                    neumaier_add(sum[t * lanes + k], comp[t * lanes + k], p[t] * v[k]);
        }
        for (std::size_t t = 0; t < count; ++t) {
            const int l = m + int(t);
            for (int ch = 0; ch < 3; ++ch) {
                const std::size_t k = t * lanes + std::size_t(ch);
                out.at(l, m, ch) = sum[k] + comp[k];
                if (m > 0) out.at(l, -m, ch) = sum[k + 3] + comp[k + 3];
            }
        }
    });
    return out;
}

// Evaluates sum_lm kernel[l] c_lm Y_lm at every texel centre; sink(j, row) receives each row's 3W values.
template <typename RowSink>
void evaluate_impl(const ShCoefficients& c, const std::vector<double>& kernel, int width, int height,
                   int threads, ShAzimuthal azimuthal, const RowSink& sink) {
    check_order(c.order);
    check_size(width, height, "output");
    const int order = c.order;
    const std::size_t uorder = std::size_t(order);
    if (c.rgb.size() != uorder * uorder * 3)
        throw InputError("spherical-harmonics coefficients hold " + std::to_string(c.rgb.size()) +
                         " values, order " + std::to_string(order) + " needs " +
                         std::to_string(uorder * uorder * 3));
    if (kernel.size() < uorder)
        throw InputError("spherical-harmonics kernel has " + std::to_string(kernel.size()) +
                         " bands, order " + std::to_string(order) + " needs " + std::to_string(order));
    threads = resolve_threads(threads);
    const ShLegendre legendre(order);
    const bool use_fft = fft_path(width, order, kFftMinOrderEvaluate, azimuthal);
    std::optional<AzimuthTable> table;
    std::optional<FftAzimuth> fft;
    if (use_fft)
        fft.emplace(width, order);
    else
        table.emplace(width, order, true);
    const int half = width / 2;
    const std::size_t uhalf = std::size_t(half);
    const bool odd = width % 2 != 0;

    parallel_for(height, threads, [&](int j) {
        double x = 0, s = 0;
        row_angles(j, height, x, s);
        std::vector<double> p(uorder * (uorder + 1) / 2);
        legendre.evaluate(x, s, p.data());
        // H_c[m] = s_m sum_l kernel[l] c_lm \bar P_lm,  K_c[m] = s_m sum_l kernel[l] c_l,-m \bar P_lm.
        std::vector<double> hk(6 * uorder, 0.0);  // H_r H_g H_b K_r K_g K_b
        for (int l = 0; l < order; ++l) {
            const double kl = kernel[std::size_t(l)];
            const double* pl = p.data() + legendre_index(l, 0);
            const double* cl = c.rgb.data() + std::size_t(l * (l + 1)) * 3;  // c_l0
            for (int m = 0; m <= l; ++m) {
                const double w = kl * pl[m];
                const double* cp = cl + 3 * m;
                const double* cn = cl - 3 * m;
                for (std::size_t ch = 0; ch < 3; ++ch) {
                    hk[ch * uorder + std::size_t(m)] += w * cp[ch];
                    if (m > 0) hk[(ch + 3) * uorder + std::size_t(m)] += w * cn[ch];
                }
            }
        }
        for (std::size_t k = 0; k < 6; ++k)
            for (std::size_t m = 1; m < uorder; ++m) hk[k * uorder + m] *= kSqrt2;

        std::vector<double> row(std::size_t(width) * 3);
        if (use_fft) {
            // Column i is Re sum_m Y_m e^(2 pi i m i / W) with Y_m = (H_m - i K_m) e^(i m phi_0). Frequencies
            // m and m + W are the same on W columns, and k and W - k carry conjugate parts of one real
            // cosine, so each Y_m is folded onto k = m mod W and then, halved and conjugated, onto
            // min(k, W - k): the spectrum of length W/2 + 1 whose real inverse is the row. The folding
            // makes orders above W/2 exact too.
            const std::size_t uwidth = std::size_t(width);
            std::vector<double> channel(uwidth);
            std::vector<std::complex<double>> spectrum(fft->plan.spectrum_size());
            for (std::size_t ch = 0; ch < 3; ++ch) {
                std::fill(spectrum.begin(), spectrum.end(), std::complex<double>(0.0, 0.0));
                const double* h = hk.data() + ch * uorder;
                const double* g = hk.data() + (ch + 3) * uorder;  // g[0] = 0: there is no c_l,-0
                for (std::size_t m = 0; m < uorder; ++m) {
                    const double cm = fft->phase_cos[m], sm = fft->phase_sin[m];
                    const double yr = h[m] * cm + g[m] * sm, yi = h[m] * sm - g[m] * cm;
                    const std::size_t k = m % uwidth;
                    if (k == 0 || 2 * k == uwidth)
                        spectrum[k] += yr;  // the inverse reads only the real part of these two
                    else if (2 * k < uwidth)
                        spectrum[k] += std::complex<double>(0.5 * yr, 0.5 * yi);
                    else
                        spectrum[uwidth - k] += std::complex<double>(0.5 * yr, -0.5 * yi);
                }
                fft->plan.inverse(spectrum.data(), channel.data());
                for (std::size_t i = 0; i < uwidth; ++i) row[3 * i + ch] = channel[i];
            }
            sink(j, row.data());
            return;
        }

        // A_c[i] = sum_m H_c[m] cos(m phi_i), B_c[i] = sum_m K_c[m] sin(m phi_i) for i < W/2; column
        // i is A + B and column W-1-i is A - B.
        std::vector<double> ab(6 * uhalf, 0.0);
        for (std::size_t m = 0; m < uorder; ++m) {
            const double* cm = table->cosines.data() + m * uhalf;
            const double* sm = table->sines.data() + m * uhalf;
            for (std::size_t k = 0; k < 3; ++k) {
                const double h = hk[k * uorder + m];
                const double g = hk[(k + 3) * uorder + m];
                double* a = ab.data() + k * uhalf;
                double* b = ab.data() + (k + 3) * uhalf;
                for (std::size_t i = 0; i < uhalf; ++i) {  // independent lanes: vectorises
                    a[i] += h * cm[i];
                    b[i] += g * sm[i];
                }
            }
        }
        for (std::size_t i = 0; i < uhalf; ++i) {
            const std::size_t mirror = std::size_t(width) - 1 - i;
            for (std::size_t k = 0; k < 3; ++k) {
                const double a = ab[k * uhalf + i];
                const double b = ab[(k + 3) * uhalf + i];
                row[3 * i + k] = a + b;
                row[3 * mirror + k] = a - b;
            }
        }
        if (odd)
            for (std::size_t k = 0; k < 3; ++k) {
                double v = 0;
                for (std::size_t m = 0; m < uorder; ++m) v += hk[k * uorder + m];
                row[3 * uhalf + k] = v;
            }
        sink(j, row.data());
    });
}

}  // namespace

ShLegendre::ShLegendre(int order) : order_(order) {
    check_order(order);
    const std::size_t n = std::size_t(order);
    diag_.assign(n, 0.0);
    for (int m = 1; m < order; ++m) diag_[std::size_t(m)] = std::sqrt((2.0 * m + 1.0) / (2.0 * m));
    a_.assign(n * (n + 1) / 2, 0.0);
    b_.assign(a_.size(), 0.0);
    for (int m = 0; m < order; ++m)
        for (int l = m + 2; l < order; ++l) {
            const double dl = l, dm = m, l1 = l - 1.0;
            const std::size_t k = column_offset(m) + std::size_t(l - m);
            a_[k] = std::sqrt((4.0 * dl * dl - 1.0) / ((dl - dm) * (dl + dm)));
            b_[k] = std::sqrt(((l1 - dm) * (l1 + dm)) / (4.0 * l1 * l1 - 1.0));
        }
}

void ShLegendre::diagonal(double s, double* out) const {
    double p = 0.5 / std::sqrt(kPi);  // \bar P_00 = 1 / sqrt(4 pi)
    out[0] = p;
    for (int m = 1; m < order_; ++m) {
        p = p == 0.0 ? 0.0 : diag_[std::size_t(m)] * s * p;
        if (std::abs(p) < kDiagonalFloor) p = 0.0;
        out[m] = p;
    }
}

void ShLegendre::column(int m, double x, double pmm, double* out) const {
    const int count = order_ - m;
    out[0] = pmm;
    if (count == 1) return;
    if (pmm == 0.0) {
        for (int t = 1; t < count; ++t) out[t] = 0.0;
        return;
    }
    out[1] = std::sqrt(2.0 * m + 3.0) * x * pmm;
    const double* a = a_.data() + column_offset(m);
    const double* b = b_.data() + column_offset(m);
    for (int t = 2; t < count; ++t) out[t] = a[t] * (x * out[t - 1] - b[t] * out[t - 2]);
}

void ShLegendre::evaluate(double x, double s, double* out) const {
    std::vector<double> diag(static_cast<std::size_t>(order_));
    std::vector<double> col(static_cast<std::size_t>(order_));
    diagonal(s, diag.data());
    for (int m = 0; m < order_; ++m) {
        column(m, x, diag[std::size_t(m)], col.data());
        for (int l = m; l < order_; ++l) out[legendre_index(l, m)] = col[std::size_t(l - m)];
    }
}

void sh_basis(int order, const Vec3& d, double* out) { sh_basis(ShLegendre(order), d, out); }

void sh_basis(const ShLegendre& legendre, const Vec3& d, double* out) {
    const double r = std::sqrt(dot(d, d));
    if (!(r > 0.0) || !std::isfinite(r)) throw InputError("spherical-harmonics direction is zero or not finite");
    const int order = legendre.order();
    const double x = std::clamp(d.y / r, -1.0, 1.0);
    const double s = std::hypot(d.x, d.z) / r;
    // phi = atan2(d.x, -d.z): cos(phi) = -z / sin(theta), sin(phi) = x / sin(theta).
    double cp = 1.0, sp = 0.0;
    if (s > 0.0) {
        cp = -d.z / (r * s);
        sp = d.x / (r * s);
    }
    std::vector<double> p(std::size_t(order) * std::size_t(order + 1) / 2);
    legendre.evaluate(x, s, p.data());
    double cm = 1.0, sm = 0.0;  // cos(m phi), sin(m phi) by angle addition
    for (int m = 0; m < order; ++m) {
        for (int l = m; l < order; ++l) {
            const double v = p[std::size_t(legendre_index(l, m))];
            if (m == 0) {
                out[l * (l + 1)] = v;
            } else {
                out[l * (l + 1) + m] = kSqrt2 * v * cm;
                out[l * (l + 1) - m] = kSqrt2 * v * sm;
            }
        }
        const double c_next = cm * cp - sm * sp;
        sm = sm * cp + cm * sp;
        cm = c_next;
    }
}

std::vector<double> fejer_weights(int height) {
    // Fejer's first rule on [-1, 1] with nodes x_j = cos(theta_j), theta_j = (j + 0.5) pi / H (the row
    // centres); exact for polynomials of degree < H (Fejer 1933; Waldvogel 2006, BIT 46, 195-202):
    //   w_j = (2/H) (1 - 2 sum_{k=1}^{floor(H/2)} cos(2 k theta_j) / (4k^2 - 1)).
    // 2 k theta_j = pi k (2j + 1) / H is reduced exactly in integers.
    if (height < 1) throw InputError("Fejer rule needs at least one row");
    std::vector<double> w(static_cast<std::size_t>(height));
    const long long period = 2LL * height;
    for (int j = 0; j < height; ++j) {
        double sum = 0.0, comp = 0.0;
        for (int k = 1; k <= height / 2; ++k) {
            const long long n = (static_cast<long long>(k) * (2LL * j + 1)) % period;
            const double angle = kPi * static_cast<double>(n) / static_cast<double>(height);
            neumaier_add(sum, comp, std::cos(angle) / (4.0 * k * k - 1.0));
        }
        w[std::size_t(j)] = (2.0 / height) * (1.0 - 2.0 * (sum + comp));
    }
    return w;
}

std::vector<double> sh_row_weights(int width, int height, ShQuadrature q) {
    check_size(width, height, "input");
    if (q == ShQuadrature::TexelSolidAngle) return row_solid_angles(width, height);
    std::vector<double> w = fejer_weights(height);
    for (double& v : w) v *= kTwoPi / width;  // the azimuthal rule: 2 pi / W per column
    return w;
}

ShCoefficients sh_project(const HdrImage& env, int order, int threads, ShQuadrature q) {
    if (env.empty()) throw InputError("spherical-harmonics projection of an empty map");
    return project_impl(env.width(), env.height(), order, threads, q, ShAzimuthal::Automatic,
                        [&](int j, double* out) {
        const float* src = env.row(j);
        for (std::size_t k = 0; k < std::size_t(env.width()) * 3; ++k) out[k] = double(src[k]);
    });
}

ShCoefficients sh_project(std::span<const double> rgb, int width, int height, int order, int threads,
                          ShQuadrature q) {
    return detail::sh_project(rgb, width, height, order, threads, q, ShAzimuthal::Automatic);
}

ShCoefficients detail::sh_project(std::span<const double> rgb, int width, int height, int order, int threads,
                                  ShQuadrature q, ShAzimuthal azimuthal) {
    check_size(width, height, "input");
    const std::size_t row_size = std::size_t(width) * 3;
    if (rgb.size() != row_size * std::size_t(height))
        throw InputError("spherical-harmonics projection: " + std::to_string(rgb.size()) +
                         " values for a " + std::to_string(width) + "x" + std::to_string(height) + " map");
    return project_impl(width, height, order, threads, q, azimuthal, [&](int j, double* out) {
        const double* src = rgb.data() + std::size_t(j) * row_size;
        for (std::size_t k = 0; k < row_size; ++k) out[k] = src[k];
    });
}

std::vector<double> phong_sh_kernel(double n, int order) {
    // Funk-Hecke: convolving with the zonal lobe f(r.w) = (n+1)/(2 pi) max(0, r.w)^n scales band l by
    //   Lambda_l rho_l = 2 pi int_{-1}^{1} f(x) P_l(x) dx = (n+1) int_0^1 x^n P_l(x) dx     (thesis eq. 2.33).
    // With I_l = int_0^1 x^n P_l(x) dx: I_0 = 1/(n+1), I_1 = 1/(n+2), and the closed form of I_l as a
    // ratio of Gamma functions gives I_l / I_{l-2} = (n - l + 2) / (n + l + 1). So k_0 = 1, k_1 = (n+1)/(n+2),
    // k_l = k_{l-2} (n - l + 2) / (n + l + 1): no factorials, any real n >= 0 (n = 1: 1, 2/3, 1/4, 0, ...).
    // The kernel needs no Legendre recurrence, so its length is not bound by kMaxShOrder.
    if (order < 1 || order > kMaxKernelBands)
        throw InputError("Phong kernel length " + std::to_string(order) + " is outside [1, " +
                         std::to_string(kMaxKernelBands) + "]");
    if (!std::isfinite(n) || n < 0.0)
        throw InputError("Phong exponent " + std::to_string(n) + " must be finite and >= 0");
    std::vector<double> k(std::size_t(order), 0.0);
    k[0] = 1.0;
    if (order > 1) k[1] = (n + 1.0) / (n + 2.0);
    for (int l = 2; l < order; ++l)
        k[std::size_t(l)] = k[std::size_t(l - 2)] * (n - l + 2.0) / (n + l + 1.0);
    return k;
}

std::vector<double> sh_evaluate(const ShCoefficients& c, const std::vector<double>& kernel, int width,
                                int height, int threads) {
    return detail::sh_evaluate(c, kernel, width, height, threads, ShAzimuthal::Automatic);
}

std::vector<double> detail::sh_evaluate(const ShCoefficients& c, const std::vector<double>& kernel, int width,
                                        int height, int threads, ShAzimuthal azimuthal) {
    check_size(width, height, "output");
    const std::size_t row_size = std::size_t(width) * 3;
    std::vector<double> out(row_size * std::size_t(height));
    evaluate_impl(c, kernel, width, height, threads, azimuthal, [&](int j, const double* row) {
        double* dst = out.data() + std::size_t(j) * row_size;
        for (std::size_t k = 0; k < row_size; ++k) dst[k] = row[k];
    });
    return out;
}

HdrImage sh_reconstruct(const ShCoefficients& c, const std::vector<double>& kernel, int width, int height,
                        int threads, long long* clamped) {
    check_size(width, height, "output");
    HdrImage out(width, height);
    std::vector<long long> negatives(std::size_t(height), 0);
    evaluate_impl(c, kernel, width, height, threads, ShAzimuthal::Automatic, [&](int j, const double* row) {
        float* dst = out.row(j);
        long long count = 0;
        for (std::size_t k = 0; k < std::size_t(width) * 3; ++k) {
            double v = row[k];
            if (v < 0.0) {
                v = 0.0;
                ++count;
            }
            dst[k] = static_cast<float>(v);
        }
        negatives[std::size_t(j)] = count;
    });
    if (clamped) {
        long long total = 0;
        for (long long n : negatives) total += n;
        *clamped = total;
    }
    return out;
}

}  // namespace glint::convolution
