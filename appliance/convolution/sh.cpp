// Spherical harmonics: stable Legendre recurrences, separable projection and reconstruction (azimuthal sums
// by FFT or directly), Phong kernel.
#include "appliance/convolution/sh.hpp"

#include <algorithm>
#include <cmath>
#include <complex>
#include <memory>
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

// The same sum with the rounding error of sum + v recovered by Knuth's TwoSum: the error is the exact one
// Neumaier's branch finds, but without the branch and the comparison, so the lanes of the blocked loops
// below vectorise.
inline void two_sum_add(double& sum, double& comp, double v) {
    const double t = sum + v;
    const double tv = t - sum;
    comp += (sum - (t - tv)) + (v - tv);
    sum = t;
}

// Start of column m in the packed triangle of an order-n table (the layout of ShLegendre's coefficients).
std::size_t packed_column(int order, int m) {
    return std::size_t(m) * std::size_t(order) - std::size_t(m) * std::size_t(m - 1) / 2;
}

// The recurrence coefficients of sh.hpp, shared by ShLegendre and column_steps. diagonal_factors: [m] =
// sqrt((2m+1)/(2m)) for m >= 1. column_coefficients: a_lm and b_lm of column m at [l - m] for l >= m + 2
// (the entries below are left alone).
std::vector<double> diagonal_factors(int order) {
    std::vector<double> diag(std::size_t(order), 0.0);
    for (int m = 1; m < order; ++m) diag[std::size_t(m)] = std::sqrt((2.0 * m + 1.0) / (2.0 * m));
    return diag;
}

void column_coefficients(int order, int m, double* a, double* b) {
    for (int l = m + 2; l < order; ++l) {
        const double dl = l, dm = m, l1 = l - 1.0;
        a[l - m] = std::sqrt((4.0 * dl * dl - 1.0) / ((dl - dm) * (dl + dm)));
        b[l - m] = std::sqrt(((l1 - dm) * (l1 + dm)) / (4.0 * l1 * l1 - 1.0));
    }
}

// \bar P_mm(cos theta) for m < order from s = sin(theta), flushed below ShLegendre::kDiagonalFloor.
void diagonal_values(const std::vector<double>& diag, int order, double s, double* out) {
    double p = 0.5 / std::sqrt(kPi);  // \bar P_00 = 1 / sqrt(4 pi)
    out[0] = p;
    for (int m = 1; m < order; ++m) {
        p = p == 0.0 ? 0.0 : diag[std::size_t(m)] * s * p;
        if (std::abs(p) < ShLegendre::kDiagonalFloor) p = 0.0;
        out[m] = p;
    }
}

// Rows j and H-1-j of an equirect map mirror each other in the equator: x = cos(theta) changes sign, s =
// sin(theta) does not, and \bar P_lm(-x) = (-1)^(l+m) \bar P_lm(x). So both separable paths run one
// Legendre recurrence per pair of rows, and split its terms by the parity of l + m: pair p is rows p and
// H-1-p for p < ceil(H/2); for an odd H the last pair is the middle row alone.
int row_pairs(int height) { return (height + 1) / 2; }

// The recurrences of several pairs run side by side, one per lane: the lanes vectorise, and their
// independent chains hide the latency of each step (a single column is a serial chain of multiply-adds).
// The projection carries 12 compensated sums per lane and sweep, the reconstruction 12 plain sums per
// lane. Measured on 1024x512 and 512x256 maps at orders 64 to 256 (4, 8 and 16 lanes for the first; 8,
// 16 and 32 for the second), 8 lanes suit the projection and 16 the reconstruction.
constexpr std::size_t kLanes = 8;
constexpr std::size_t kEvaluateLanes = 16;

// The column recurrence as the blocked paths run it, with the step to \bar P_m+1,m folded in:
//   p_0 = \bar P_mm, p_-1 = 0,  p_t = a_t (x p_t-1 - b_t p_t-2) for t = l - m >= 1,
// where a_1 = sqrt(2m+3), b_1 = 0 and a_t, b_t = a_lm, b_lm of sh.hpp above: a[t], b[t] for t in
// [1, order - m). The projection computes each column in the task that sums it; the reconstruction
// needs them all in every task and tabulates them first, on all its threads from kParallelTableOrder on:
// the order^2 square roots and divisions take 0.27 ms at order 224, a tenth of a reconstruction to
// 512x256, while starting a thread costs about 0.06 ms, as much as half the table at order 160.
constexpr int kParallelTableOrder = 160;

void column_steps(int order, int m, double* a, double* b) {
    column_coefficients(order, m, a, b);
    if (m + 1 < order) {
        a[1] = std::sqrt(2.0 * m + 3.0);
        b[1] = 0.0;
    }
}

// diagonal_values for kEvaluateLanes values of s = sin(theta) at once: out[m * kEvaluateLanes + lane].
void lane_diagonals(const std::vector<double>& diag, int order, const double* s, double* out) {
    constexpr std::size_t L = kEvaluateLanes;
    double p[L];
    for (std::size_t lane = 0; lane < L; ++lane) out[lane] = p[lane] = 0.5 / std::sqrt(kPi);
    for (std::size_t m = 1; m < std::size_t(order); ++m) {
        const double dm = diag[m];
#pragma omp simd
        for (std::size_t lane = 0; lane < L; ++lane) {
            double v = p[lane] == 0.0 ? 0.0 : dm * s[lane] * p[lane];
            if (std::abs(v) < ShLegendre::kDiagonalFloor) v = 0.0;
            p[lane] = v;
            out[m * L + lane] = v;
        }
    }
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

// For kEvaluateLanes row pairs at once, the sums of one column m of the reconstruction over its degrees
// t = l - m apart by parity: even[lane * stride + k * step] = sum over even t of p_t d[t * 6 + k], odd
// likewise over odd t, for the count = order - m values p_t of the recurrence (column_steps a, b) at
// x[lane] from p_0 = pmm[lane]. Each step is one loop over the lanes, which vectorises.
void column_sums(const double* a, const double* b, const double* d, std::size_t count, const double* x,
                 const double* pmm, double* even, double* odd, std::size_t stride, std::size_t step) {
    constexpr std::size_t L = kEvaluateLanes;
    double p1[L], p2[L], e[6][L], o[6][L];
#pragma omp simd
    for (std::size_t lane = 0; lane < L; ++lane) {
        p1[lane] = pmm[lane];
        p2[lane] = 0.0;
        for (std::size_t k = 0; k < 6; ++k) {
            e[k][lane] = p1[lane] * d[k];
            o[k][lane] = 0.0;
        }
    }
    for (std::size_t t = 1; t < count; ++t) {
        const double at = a[t], bt = b[t];
        const double* dt = d + t * 6;
        double (*sums)[L] = t % 2 ? o : e;
#pragma omp simd
        for (std::size_t lane = 0; lane < L; ++lane) {
            const double p = at * (x[lane] * p1[lane] - bt * p2[lane]);
            p2[lane] = p1[lane];
            p1[lane] = p;
            for (std::size_t k = 0; k < 6; ++k) sums[k][lane] += p * dt[k];
        }
    }
    for (std::size_t lane = 0; lane < L; ++lane)
        for (std::size_t k = 0; k < 6; ++k) {
            even[lane * stride + k * step] = e[k][lane];
            odd[lane * stride + k * step] = o[k][lane];
        }
}

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
// W - (m mod W), so any order works with any width. Where each frequency lands is tabulated once per call
// (an integer division per frequency and row costs as much as the rest of the folding).
struct FftAzimuth {
    RealFftPlan plan;
    std::vector<double> phase_cos, phase_sin;  // cos(m phi_0), sin(m phi_0) for m < order
    std::vector<std::size_t> bin;              // min(k, W - k) for k = m mod W: the spectrum value of m
    std::vector<double> conj_sign;             // -1 where k > W/2 (X_k = conj X_(W-k)), else 1
    // The synthesis adds fold_re Re Y_m and fold_im Im Y_m to spectrum[bin]: 1 and 0 at k = 0 and k = W/2
    // (the inverse reads only their real parts), 1/2 and +-1/2 elsewhere (k and W - k share a cosine).
    std::vector<double> fold_re, fold_im;

    FftAzimuth(int width, int order) : plan(std::size_t(width)) {
        const std::size_t n = std::size_t(order), uwidth = std::size_t(width);
        phase_cos.resize(n);
        phase_sin.resize(n);
        bin.resize(n);
        conj_sign.resize(n);
        fold_re.resize(n);
        fold_im.resize(n);
        for (std::size_t m = 0; m < n; ++m) {
            column_angle(int(m), 0, width, phase_cos[m], phase_sin[m]);
            const std::size_t k = m % uwidth;
            const bool mirrored = 2 * k > uwidth;
            bin[m] = mirrored ? uwidth - k : k;
            conj_sign[m] = mirrored ? -1.0 : 1.0;
            const bool real_only = k == 0 || 2 * k == uwidth;
            fold_re[m] = real_only ? 1.0 : 0.5;
            fold_im[m] = real_only ? 0.0 : (mirrored ? -0.5 : 0.5);
        }
    }
};

// The azimuthal sums of one call: by FFT, or by a table of direct cosines and
// sines (only the path taken builds its table: the direct one is O(W order)).
struct Azimuth {
    std::optional<AzimuthTable> table;
    std::optional<FftAzimuth> fft;
};
Azimuth choose_azimuth(int width, int order, int min_fft_order, ShAzimuthal azimuthal, bool synthesis) {
    Azimuth a;
    if (fft_path(width, order, min_fft_order, azimuthal))
        a.fft.emplace(width, order);
    else
        a.table.emplace(width, order, synthesis);
    return a;
}

// Polar angle of a row centre: x = cos(theta), s = sin(theta) > 0.
void row_angles(int j, int height, double& x, double& s) {
    const double theta = row_theta(j, height);
    x = std::cos(theta);
    s = std::sin(theta);
}

// The projection of rows read in double by read_row(j, out[3W]), channel by channel (out[c * W + i]: the
// transforms take each channel contiguous); shared by the float and double inputs.
// Adds v to sum, with the rounding error into comp when Compensated.
template <bool Compensated>
inline void accumulate(double& sum, double& comp, double v) {
    if constexpr (Compensated)
        two_sum_add(sum, comp, v);
    else
        sum += v;
}

// spectra (optional, FFT path only): the rows' spectra given, read_row never called.
// image (optional): the same rows as read_row, from a float map; on the FFT path its rows are
// transformed FftPlan::kBatch at a time (RealFftPlan::forward_batch, one row per vector lane).
template <bool Compensated, typename RowSource>
ShCoefficients project_impl(int width, int height, int order, int threads, ShQuadrature q,
                            ShAzimuthal azimuthal, const RowSource& read_row,
                            const RowSpectrumSource* spectra = nullptr, const HdrImage* image = nullptr) {
    check_order(order);
    check_size(width, height, "input");
    threads = resolve_threads(threads);
    const std::vector<double> diag = diagonal_factors(order);
    const auto [table, fft] = choose_azimuth(width, order, kFftMinOrderProject, azimuthal, false);
    const bool use_fft = fft.has_value();
    const std::vector<double> weights = sh_row_weights(width, height, q);
    const std::size_t uorder = std::size_t(order);
    const int half = width / 2;
    const std::size_t uhalf = std::size_t(half);
    const bool odd = width % 2 != 0;

    // Pass 1, per row j: weighted Fourier sums over the columns, 6 arrays of length order
    //   F_c[m] = w_j s_m sum_i L_c,i cos(m phi_i),  G_c[m] = w_j s_m sum_i L_c,i sin(m phi_i)
    // (s_0 = 1, s_m = sqrt2). The sums cost O(W log W) by FFT for a power-of-two width and O(W order)
    // directly otherwise.
    const std::size_t uwidth = std::size_t(width);
    // Channel ch's F_m - i G_m from the row's spectrum X (real part of bin k at re[k * stride],
    // imaginary part at im[k * stride]): X at m's bin, conjugated above W/2, turned by the phase of
    // column 0, (c - i s)(a + i b) = F - i G.
    const auto from_spectrum = [&](std::size_t ch, const double* re, const double* im, std::size_t stride,
                                   double* f) {
        double* fc = f + ch * uorder;
        double* gc = f + (ch + 3) * uorder;
        for (std::size_t m = 0; m < uorder; ++m) {
            const std::size_t k = fft->bin[m] * stride;
            const double a = re[k], b = fft->conj_sign[m] * im[k];
            const double c = fft->phase_cos[m], s = fft->phase_sin[m];
            fc[m] = c * a + s * b;
            gc[m] = s * a - c * b;
        }
    };
    // The row's quadrature weight and s_m.
    const auto weigh = [&](int j, double* f) {
        const double w = weights[std::size_t(j)];
        for (std::size_t k = 0; k < 6; ++k)
            for (std::size_t m = 0; m < uorder; ++m) f[k * uorder + m] *= m == 0 ? w : w * kSqrt2;
    };
    const auto fourier_sums = [&](int j, std::vector<double>& row, double* f) {
        if (!spectra) read_row(j, row.data());
        double* fr = f;  // F_r F_g F_b G_r G_g G_b
        double* fg = f + uorder;
        double* fb = f + 2 * uorder;
        double* gr = f + 3 * uorder;
        double* gg = f + 4 * uorder;
        double* gb = f + 5 * uorder;
        if (use_fft && spectra) {  // planar: per channel its real parts, then its imaginary parts
            const double* x = (*spectra)(j);
            const std::size_t bins = fft->plan.spectrum_size();
            for (std::size_t ch = 0; ch < 3; ++ch) from_spectrum(ch, x + 2 * ch * bins, x + (2 * ch + 1) * bins, 1, f);
        } else if (use_fft) {
            thread_local std::vector<std::complex<double>> spectrum;  // written whole by forward()
            spectrum.resize(fft->plan.spectrum_size());
            // [complex.numbers]: an array of complex<double> reads as interleaved (re, im) doubles.
            const double* x = reinterpret_cast<const double*>(spectrum.data());
            for (std::size_t ch = 0; ch < 3; ++ch) {
                fft->plan.forward(row.data() + ch * uwidth, spectrum.data());
                from_spectrum(ch, x, x + 1, 2, f);
            }
        } else {
            std::fill(f, f + 6 * uorder, 0.0);
            const double* r = row.data();
            const double* gn = r + uwidth;
            const double* bl = r + 2 * uwidth;
            for (int i = 0; i < half; ++i) {
                const std::size_t a = std::size_t(i), b = std::size_t(width - 1 - i);
                const double s0 = r[a] + r[b], s1 = gn[a] + gn[b], s2 = bl[a] + bl[b];
                const double d0 = r[a] - r[b], d1 = gn[a] - gn[b], d2 = bl[a] - bl[b];
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
                const std::size_t c = uhalf;
                for (std::size_t m = 0; m < uorder; ++m) {
                    fr[m] += r[c];
                    fg[m] += gn[c];
                    fb[m] += bl[c];
                }
            }
        }
        weigh(j, f);
    };

    // Pass 2 takes the columns m in groups of kColumnGroup, so pass 1 stores its results by group: the
    // sums at [((g * H + j) * 6 + k) * kColumnGroup + i] for m = g kColumnGroup + i and part k (cos r g b,
    // sin r g b), and for the upper row of each pair p (see row_pairs) \bar P_mm(cos theta_p) at
    // [(g * pairs + p) * kColumnGroup + i] and x_p at [p]. A group then reads one contiguous run.
    constexpr std::size_t kColumnGroup = 8;
    const std::size_t groups = (uorder + kColumnGroup - 1) / kColumnGroup;
    const std::size_t uheight = std::size_t(height), upairs = std::size_t(row_pairs(height));
    const std::size_t blocks = (upairs + kLanes - 1) / kLanes, padded = blocks * kLanes;
    // Not zeroed: pass 1 writes every value pass 2 reads (those of m < order).
    const auto fourier = std::make_unique_for_overwrite<double[]>(groups * uheight * 6 * kColumnGroup);
    const auto diagonal = std::make_unique_for_overwrite<double[]>(groups * upairs * kColumnGroup);
    std::vector<double> xs(padded, 0.0);  // the lanes past the last pair hold 0
    // Row j's sums f (6 order values, overwritten after use) into fourier and diagonal.
    const auto store_row = [&](int j, double* f) {
        const std::size_t uj = std::size_t(j);
        for (std::size_t g = 0; g < groups; ++g) {
            const std::size_t m0 = g * kColumnGroup, mn = std::min(kColumnGroup, uorder - m0);
            double* dst = fourier.get() + (g * uheight + uj) * 6 * kColumnGroup;
            // A whole group is a copy of fixed length, inlined; copy_n of a run-time count was a
            // library call per 8 values (6 per group, 180 a row at order 236).
            for (std::size_t k = 0; k < 6; ++k) {
                const double* src = f + k * uorder + m0;
                if (mn == kColumnGroup)
                    for (std::size_t i = 0; i < kColumnGroup; ++i) dst[k * kColumnGroup + i] = src[i];
                else
                    for (std::size_t i = 0; i < mn; ++i) dst[k * kColumnGroup + i] = src[i];
            }
        }
        if (uj >= upairs) return;
        double s = 0;
        row_angles(j, height, xs[uj], s);
        diagonal_values(diag, order, s, f);  // f is free again
        for (std::size_t m = 0; m < uorder; ++m)
            diagonal[((m / kColumnGroup) * upairs + uj) * kColumnGroup + m % kColumnGroup] = f[m];
    };
    if (use_fft && !spectra && image) {
        // A float map's rows kBatch at a time, each channel one batched transform: a single row's
        // forward() was a fifth of a 128x64 n = 1280 map's time from 1024x512 (order 236).
        constexpr std::size_t kBatch = FftPlan::kBatch;
        const std::size_t bins = fft->plan.spectrum_size();
        const int batches = int((uheight + kBatch - 1) / kBatch);
        parallel_for(batches, threads, [&](int batch) {
            // Per thread: planes of the batch's rows (one channel), their spectra (per row and
            // channel: real parts, then imaginary parts) and one row's sums.
            thread_local std::vector<float> planes;
            thread_local std::vector<double> spectrum, f;
            planes.resize(kBatch * uwidth);
            spectrum.resize(kBatch * 6 * bins);
            f.resize(6 * uorder);
            const int first = batch * int(kBatch);
            const std::size_t count = std::min(kBatch, uheight - std::size_t(first));
            for (std::size_t ch = 0; ch < 3; ++ch) {
                const float* x[kBatch];
                double* re[kBatch];
                double* im[kBatch];
                for (std::size_t b = 0; b < count; ++b) {
                    const float* src = image->row(first + int(b));
                    float* plane = planes.data() + b * uwidth;
                    for (std::size_t i = 0; i < uwidth; ++i) plane[i] = src[3 * i + ch];
                    x[b] = plane;
                    re[b] = spectrum.data() + (b * 6 + 2 * ch) * bins;
                    im[b] = re[b] + bins;
                }
                fft->plan.forward_batch(x, re, im, count);
            }
            for (std::size_t b = 0; b < count; ++b) {
                const int j = first + int(b);
                const double* x = spectrum.data() + b * 6 * bins;
                for (std::size_t ch = 0; ch < 3; ++ch)
                    from_spectrum(ch, x + 2 * ch * bins, x + (2 * ch + 1) * bins, 1, f.data());
                weigh(j, f.data());
                store_row(j, f.data());
            }
        });
    } else {
        // From given spectra, rows in aligned runs of FftPlan::kBatch: the Fourier pass's source
        // transforms a run's rows together when one of them is first read
        // (PreparedLevel::row_spectrum), so with a thread per row the other thread waited for every
        // run's transforms (3.4 ms of a 4.9 ms pass idle, studio's order-236 projection of
        // 1024x512). From read rows, one row per task.
        const int run = spectra ? int(FftPlan::kBatch) : 1;
        parallel_for((height + run - 1) / run, threads, [&](int r) {
            // Per thread, not per row: fresh vectors cost an allocation and a zero fill each row (every
            // value read is written first: read_row fills `row`, fourier_sums all of `f`).
            thread_local std::vector<double> row, f;
            if (!spectra) row.resize(uwidth * 3);
            f.resize(6 * uorder);
            for (int j = r * run; j < std::min(height, (r + 1) * run); ++j) {
                fourier_sums(j, row, f.data());
                store_row(j, f.data());
            }
        });
    }

    // Pass 2, per m (disjoint coefficients): c_lm = sum_j \bar P_lm(x_j) F_j[m]. With the mirror rows
    // folded (see row_pairs) this is sum over pairs p of \bar P_lm(x_p) (F_p[m] +- F_H-1-p[m]), + for even
    // l + m and - for odd, so each recurrence runs over half the rows. Lane q of the blocks of kLanes
    // pairs sums the pairs q, q + kLanes, q + 2 kLanes, ... in that order with compensated sums, and the
    // lanes are then added in lane order: a fixed order, so the result does not depend on the thread
    // count. Each sweep over the blocks takes two degrees, an odd and the next even one, carrying the last
    // two values of every lane from sweep to sweep: the sums of a sweep stay in registers or the L1 cache.
    ShCoefficients out;
    out.order = order;
    out.rgb.assign(uorder * uorder * 3, 0.0);
    // Column m from its pmm[p] and folded sums plus/minus[k * stride + p] (see below).
    const auto project_column = [&](int m, const double* pmm, const double* plus, const double* minus,
                                    std::size_t stride) {
        const std::size_t count = uorder - std::size_t(m);
        std::vector<char> live(blocks, 0);  // some lane's \bar P_mm has not underflowed
        for (std::size_t p = 0; p < upairs; ++p)
            if (pmm[p] != 0.0) live[p / kLanes] = 1;
        const auto finish = [&](std::size_t t, const double (*sum)[kLanes], const double (*comp)[kLanes]) {
            const int l = m + int(t);
            for (std::size_t k = 0; k < (m == 0 ? 3u : 6u); ++k) {
                double total = 0.0, error = 0.0;
                for (std::size_t lane = 0; lane < kLanes; ++lane) {
                    accumulate<Compensated>(total, error, sum[k][lane]);
                    error += comp[k][lane];
                }
                if (k < 3)
                    out.at(l, m, int(k)) = total + error;
                else
                    out.at(l, -m, int(k) - 3) = total + error;
            }
        };
        std::vector<double> last(2 * padded, 0.0);  // p_t-1 and p_t-2 of every lane between sweeps
        {  // degree 0: \bar P_mm itself
            double sum[6][kLanes] = {}, comp[6][kLanes] = {};
            for (std::size_t blk = 0; blk < blocks; ++blk) {
                if (!live[blk]) continue;
                const double* pm = pmm + blk * kLanes;
                const double* pl = plus + blk * kLanes;
                for (std::size_t k = 0; k < 6; ++k)
#pragma omp simd
                    for (std::size_t lane = 0; lane < kLanes; ++lane)
                        accumulate<Compensated>(sum[k][lane], comp[k][lane], pm[lane] * pl[k * stride + lane]);
            }
            std::copy_n(pmm, padded, last.begin());
            finish(0, sum, comp);
        }
        std::vector<double> ca(count, 0.0), cb(count, 0.0);
        column_steps(order, m, ca.data(), cb.data());
        for (std::size_t t = 1; t < count; t += 2) {
            // Degree t (odd l + m) reads minus, degree t + 1 (even) plus; past the column's end the second
            // step runs with zero coefficients and is not stored.
            const bool second = t + 1 < count;
            const double a1 = ca[t], b1 = cb[t];
            const double a2 = second ? ca[t + 1] : 0.0, b2 = second ? cb[t + 1] : 0.0;
            double sum_odd[6][kLanes] = {}, comp_odd[6][kLanes] = {};
            double sum_even[6][kLanes] = {}, comp_even[6][kLanes] = {};
            for (std::size_t blk = 0; blk < blocks; ++blk) {
                if (!live[blk]) continue;  // every value of the column is 0
                const std::size_t base = blk * kLanes;
                double* p1 = last.data() + base;
                double* p2 = last.data() + padded + base;
                const double* xb = xs.data() + base;
                const double* mi = minus + base;
                const double* pl = plus + base;
#pragma omp simd
                for (std::size_t lane = 0; lane < kLanes; ++lane) {
                    const double po = a1 * (xb[lane] * p1[lane] - b1 * p2[lane]);
                    for (std::size_t k = 0; k < 6; ++k)
                        accumulate<Compensated>(sum_odd[k][lane], comp_odd[k][lane], po * mi[k * stride + lane]);
                    const double pe = a2 * (xb[lane] * po - b2 * p1[lane]);
                    for (std::size_t k = 0; k < 6; ++k)
                        accumulate<Compensated>(sum_even[k][lane], comp_even[k][lane], pe * pl[k * stride + lane]);
                    p2[lane] = po;
                    p1[lane] = pe;
                }
            }
            finish(t, sum_odd, comp_odd);
            if (second) finish(t + 1, sum_even, comp_even);
        }
    };
    // A task takes one group of columns and folds per column m = m0 + i and pair p (padded with zero
    // lanes, which add exact zeros) the sums plus = F_p + F_mirror, minus = F_p - F_mirror (both F_p for
    // the middle row of an odd height) into [(i * 6 + k) * stride + p], and \bar P_mm into [i * padded + p].
    // The stride is padded by one block: a power of two would map the 96 arrays onto the same cache sets.
    const std::size_t stride = padded + kLanes;
    parallel_for(int(groups), threads, [&](int group) {
        const std::size_t ug = std::size_t(group);
        const std::size_t m0 = ug * kColumnGroup, mn = std::min(kColumnGroup, uorder - m0);
        std::vector<double> pmm(mn * padded, 0.0), plus(mn * 6 * stride, 0.0), minus(mn * 6 * stride, 0.0);
        for (std::size_t p = 0; p < upairs; ++p) {
            const std::size_t mirror = uheight - 1 - p;
            for (std::size_t i = 0; i < mn; ++i)
                pmm[i * padded + p] = diagonal[(ug * upairs + p) * kColumnGroup + i];
            for (std::size_t k = 0; k < 6; ++k) {
                const double* f = fourier.get() + ((ug * uheight + p) * 6 + k) * kColumnGroup;
                const double* g = fourier.get() + ((ug * uheight + mirror) * 6 + k) * kColumnGroup;
                for (std::size_t i = 0; i < mn; ++i) {
                    const double fa = f[i], fb = mirror == p ? 0.0 : g[i];
                    plus[(i * 6 + k) * stride + p] = fa + fb;
                    minus[(i * 6 + k) * stride + p] = fa - fb;
                }
            }
        }
        for (std::size_t i = 0; i < mn; ++i)
            project_column(int(m0 + i), pmm.data() + i * padded, plus.data() + i * 6 * stride,
                           minus.data() + i * 6 * stride, stride);
    });
    return out;
}

// Evaluates sum_lm kernel[l] c_lm Y_lm at every texel centre; sink(j, row) receives each row's 3W values.
// Only the first `order` bands of c are read (order <= c.order).
template <typename RowSink>
void evaluate_impl(const ShCoefficients& c, int order, const std::vector<double>& kernel, int width, int height,
                   int threads, ShAzimuthal azimuthal, const RowSink& sink) {
    check_order(order);
    check_size(width, height, "output");
    const std::size_t uorder = std::size_t(order);
    if (order > c.order || c.rgb.size() != std::size_t(c.order) * std::size_t(c.order) * 3)
        throw InputError("spherical-harmonics coefficients hold " + std::to_string(c.rgb.size()) +
                         " values of order " + std::to_string(c.order) + "; order " + std::to_string(order) +
                         " needs " + std::to_string(uorder * uorder * 3));
    if (kernel.size() < uorder)
        throw InputError("spherical-harmonics kernel has " + std::to_string(kernel.size()) +
                         " bands, order " + std::to_string(order) + " needs " + std::to_string(order));
    threads = resolve_threads(threads);
    const std::vector<double> diag = diagonal_factors(order);
    const auto [table, fft] = choose_azimuth(width, order, kFftMinOrderEvaluate, azimuthal, true);
    const bool use_fft = fft.has_value();
    const int half = width / 2;
    const std::size_t uhalf = std::size_t(half);
    const bool odd = width % 2 != 0;

    // Every block of rows runs every column, so the columns' recurrence coefficients (column_steps) are
    // tabulated first, at packed_column(order, m) + t, with the coefficients as the recurrences read
    // them: for column m and t = l - m, the 6 values
    //   s_m kernel[l] (c_lm r g b, c_l,-m r g b)      (s_0 = 1, s_m = sqrt2; no c_l,-0: zeros for m = 0)
    // contiguous at (packed_column(order, m) + t) * 6, so each step reads one short run.
    const std::size_t packed = uorder * (uorder + 1) / 2;
    std::vector<double> steps_a(packed, 0.0), steps_b(packed, 0.0), weighted(packed * 6, 0.0);
    parallel_for(order, order >= kParallelTableOrder ? threads : 1, [&](int m) {
        const std::size_t column = packed_column(order, m);
        column_steps(order, m, steps_a.data() + column, steps_b.data() + column);
        for (int l = m; l < order; ++l) {
            const double w = kernel[std::size_t(l)] * (m == 0 ? 1.0 : kSqrt2);
            double* d = weighted.data() + (column + std::size_t(l - m)) * 6;
            for (int ch = 0; ch < 3; ++ch) {
                d[ch] = w * c.at(l, m, ch);
                if (m > 0) d[3 + ch] = w * c.at(l, -m, ch);
            }
        }
    });

    // Writes row j from its azimuthal series hk = H_r H_g H_b K_r K_g K_b (order values each),
    //   H_c[m] = s_m sum_l kernel[l] c_lm \bar P_lm,  K_c[m] = s_m sum_l kernel[l] c_l,-m \bar P_lm;
    // the buffers are reused from row to row.
    struct RowBuffers {
        std::vector<double> row, channel, ab;
        std::vector<std::complex<double>> spectrum;
    };
    const std::size_t uwidth = std::size_t(width);
    const auto synthesise = [&](int j, const double* hk, RowBuffers& buf) {
        std::vector<double>& row = buf.row;
        if (use_fft) {
            // Column i is Re sum_m Y_m e^(2 pi i m i / W) with Y_m = (H_m - i K_m) e^(i m phi_0). Frequencies
            // m and m + W are the same on W columns, and k and W - k carry conjugate parts of one real
            // cosine, so each Y_m is folded onto k = m mod W and then, halved and conjugated, onto
            // min(k, W - k): the spectrum of length W/2 + 1 whose real inverse is the row. The folding
            // makes orders above W/2 exact too.
            // Three spectra (one per channel, bins at ch * bins), then one batched inverse.
            const std::size_t bins = fft->plan.spectrum_size();
            for (std::size_t ch = 0; ch < 3; ++ch) {
                const auto spectrum = buf.spectrum.begin() + std::ptrdiff_t(ch * bins);
                // std::complex<double> is laid out as two doubles, real part first ([complex.numbers]).
                double* sp = reinterpret_cast<double*>(buf.spectrum.data() + ch * bins);
                const double* h = hk + ch * uorder;
                const double* g = hk + (ch + 3) * uorder;  // g[0] = 0: there is no c_l,-0
                const double* cm = fft->phase_cos.data();
                const double* sm = fft->phase_sin.data();
                if (2 * uorder <= uwidth) {
                    // No folding below W/2: frequency m fills bin m, halved but at m = 0, and the bins
                    // above the order are 0. A plain loop, which vectorises.
                    sp[0] = h[0] * cm[0] + g[0] * sm[0];
                    sp[1] = 0.0;
                    for (std::size_t m = 1; m < uorder; ++m) {
                        sp[2 * m] = 0.5 * (h[m] * cm[m] + g[m] * sm[m]);
                        sp[2 * m + 1] = 0.5 * (h[m] * sm[m] - g[m] * cm[m]);
                    }
                    std::fill(spectrum + std::ptrdiff_t(uorder), spectrum + std::ptrdiff_t(bins),
                              std::complex<double>(0.0, 0.0));
                } else {
                    std::fill(spectrum, spectrum + std::ptrdiff_t(bins), std::complex<double>(0.0, 0.0));
                    for (std::size_t m = 0; m < uorder; ++m) {
                        const double yr = h[m] * cm[m] + g[m] * sm[m], yi = h[m] * sm[m] - g[m] * cm[m];
                        const std::size_t k = fft->bin[m];
                        sp[2 * k] += fft->fold_re[m] * yr;
                        sp[2 * k + 1] += fft->fold_im[m] * yi;
                    }
                }
            }
            const std::complex<double>* spectra[3];
            double* channels[3];
            for (std::size_t ch = 0; ch < 3; ++ch) {
                spectra[ch] = buf.spectrum.data() + ch * bins;
                channels[ch] = buf.channel.data() + ch * uwidth;
            }
            fft->plan.inverse_batch(spectra, channels, 3);
            for (std::size_t ch = 0; ch < 3; ++ch)
                for (std::size_t i = 0; i < uwidth; ++i) row[3 * i + ch] = channels[ch][i];
            sink(j, row.data());
            return;
        }

        // A_c[i] = sum_m H_c[m] cos(m phi_i), B_c[i] = sum_m K_c[m] sin(m phi_i) for i < W/2; column
        // i is A + B and column W-1-i is A - B.
        std::vector<double>& ab = buf.ab;
        std::fill(ab.begin(), ab.end(), 0.0);
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
            const std::size_t mirror = uwidth - 1 - i;
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
    };

    // Per block of kEvaluateLanes row pairs (see row_pairs), per column m: one recurrence per pair, whose
    // terms are summed apart by the parity of l + m, even[k] and odd[k] (k: H r g b, K r g b). Row p then
    // has H, K = even + odd, and its mirror H-1-p has even - odd.
    constexpr std::size_t L = kEvaluateLanes;
    const std::size_t upairs = std::size_t(row_pairs(height));
    const std::size_t blocks = (upairs + L - 1) / L;
    // Per lane the sums are laid out like hk, [lane * stride + k * order + m]; the stride is padded by 8
    // values, as a power of two would map the lanes onto the same cache sets.
    const std::size_t stride = 6 * uorder + 8;
    parallel_for(int(blocks), threads, [&](int blk) {
        const std::size_t base = std::size_t(blk) * L;
        const std::size_t lanes = std::min(L, upairs - base);  // the rest are padding, held at 0
        double x[L] = {}, s[L] = {};
        for (std::size_t lane = 0; lane < lanes; ++lane)
            row_angles(int(base + lane), height, x[lane], s[lane]);
        std::vector<double> pmm(uorder * L);  // [m * L + lane]
        lane_diagonals(diag, order, s, pmm.data());
        for (std::size_t m = 0; m < uorder; ++m)
            for (std::size_t lane = lanes; lane < L; ++lane) pmm[m * L + lane] = 0.0;
        // Not zeroed: every value is written below, by column_sums or as a column of zeros.
        const auto even = std::make_unique_for_overwrite<double[]>(L * stride);
        const auto odd_sums = std::make_unique_for_overwrite<double[]>(L * stride);
        for (std::size_t m = 0; m < uorder; ++m) {
            const double* pm = pmm.data() + m * L;
            if (std::all_of(pm, pm + L, [](double v) { return v == 0.0; })) {
                // underflowed at the pole: every value of the column is 0
                for (std::size_t lane = 0; lane < L; ++lane)
                    for (std::size_t k = 0; k < 6; ++k) {
                        even[lane * stride + k * uorder + m] = 0.0;
                        odd_sums[lane * stride + k * uorder + m] = 0.0;
                    }
                continue;
            }
            const std::size_t column = packed_column(order, int(m));
            column_sums(steps_a.data() + column, steps_b.data() + column, weighted.data() + column * 6,
                        uorder - m, x, pm, even.get() + m, odd_sums.get() + m, stride, uorder);
        }
        RowBuffers buf;
        buf.row.resize(uwidth * 3);
        if (use_fft) {
            buf.channel.resize(3 * uwidth);
            buf.spectrum.resize(3 * fft->plan.spectrum_size());
        } else {
            buf.ab.resize(6 * uhalf);
        }
        std::vector<double> hk(6 * uorder);
        for (std::size_t lane = 0; lane < lanes; ++lane) {
            const int j = int(base + lane), mirror = height - 1 - j;
            const double* e = even.get() + lane * stride;
            const double* o = odd_sums.get() + lane * stride;
            for (std::size_t k = 0; k < 6 * uorder; ++k) hk[k] = e[k] + o[k];
            synthesise(j, hk.data(), buf);
            if (mirror == j) continue;  // the middle row of an odd height has no mirror
            for (std::size_t k = 0; k < 6 * uorder; ++k) hk[k] = e[k] - o[k];
            synthesise(mirror, hk.data(), buf);
        }
    });
}

}  // namespace

ShLegendre::ShLegendre(int order) : order_(order) {
    check_order(order);
    diag_ = diagonal_factors(order);
    const std::size_t n = std::size_t(order);
    a_.assign(n * (n + 1) / 2, 0.0);
    b_.assign(a_.size(), 0.0);
    for (int m = 0; m < order; ++m)
        column_coefficients(order, m, a_.data() + column_offset(m), b_.data() + column_offset(m));
}

void ShLegendre::diagonal(double s, double* out) const { diagonal_values(diag_, order_, s, out); }

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

void ShLegendre::zonal(double x, double* out) const { column(0, x, 0.5 / std::sqrt(kPi), out); }

void ShLegendre::evaluate(double x, double s, double* out) const {
    std::vector<double> diag(static_cast<std::size_t>(order_));
    std::vector<double> col(static_cast<std::size_t>(order_));
    diagonal(s, diag.data());
    for (int m = 0; m < order_; ++m) {
        column(m, x, diag[std::size_t(m)], col.data());
        for (int l = m; l < order_; ++l) out[legendre_index(l, m)] = col[std::size_t(l - m)];
    }
}

void sh_basis(int order, const glm::dvec3& d, double* out) { sh_basis(ShLegendre(order), d, out); }

void sh_basis(const ShLegendre& legendre, const glm::dvec3& d, double* out) {
    const double r = glm::length(d);
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

ShCoefficients sh_project(const HdrImage& env, int order, int threads, ShQuadrature q, ShSummation summation) {
    if (env.empty()) throw InputError("spherical-harmonics projection of an empty map");
    const std::size_t width = std::size_t(env.width());
    const auto read_row = [&](int j, double* out) {
        const float* src = env.row(j);
        for (std::size_t i = 0; i < width; ++i)
            for (std::size_t ch = 0; ch < 3; ++ch) out[ch * width + i] = double(src[3 * i + ch]);
    };
    if (summation == ShSummation::Plain)
        return project_impl<false>(env.width(), env.height(), order, threads, q, ShAzimuthal::Automatic, read_row,
                                   nullptr, &env);
    return project_impl<true>(env.width(), env.height(), order, threads, q, ShAzimuthal::Automatic, read_row,
                              nullptr, &env);
}

ShCoefficients sh_project_spectra(int width, int height, int order, int threads, const RowSpectrumSource& spectrum_of_row,
                                  ShQuadrature q, ShSummation summation) {
    check_size(width, height, "input");
    const auto no_rows = [](int, double*) { throw RuntimeError("internal: sh_project_spectra reads no rows"); };
    if (summation == ShSummation::Plain)
        return project_impl<false>(width, height, order, threads, q, ShAzimuthal::Fft, no_rows, &spectrum_of_row);
    return project_impl<true>(width, height, order, threads, q, ShAzimuthal::Fft, no_rows, &spectrum_of_row);
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
    const std::size_t uwidth = std::size_t(width);
    return project_impl<true>(width, height, order, threads, q, azimuthal, [&](int j, double* out) {
        const double* src = rgb.data() + std::size_t(j) * row_size;
        for (std::size_t i = 0; i < uwidth; ++i)
            for (std::size_t ch = 0; ch < 3; ++ch) out[ch * uwidth + i] = src[3 * i + ch];
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

void sh_column_steps(int order, int m, double* a, double* b) { column_steps(order, m, a, b); }

void sh_diagonal(int order, double s, double* out) { diagonal_values(diagonal_factors(order), order, s, out); }

void sh_evaluate_rows(const ShCoefficients& c, int order, const std::vector<double>& kernel, int width, int height,
                      int threads, const std::function<void(int, const double*)>& sink) {
    evaluate_impl(c, order, kernel, width, height, threads, ShAzimuthal::Automatic, sink);
}

std::vector<double> detail::sh_evaluate(const ShCoefficients& c, const std::vector<double>& kernel, int width,
                                        int height, int threads, ShAzimuthal azimuthal) {
    check_size(width, height, "output");
    const std::size_t row_size = std::size_t(width) * 3;
    std::vector<double> out(row_size * std::size_t(height));
    evaluate_impl(c, c.order, kernel, width, height, threads, azimuthal, [&](int j, const double* row) {
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
    evaluate_impl(c, c.order, kernel, width, height, threads, ShAzimuthal::Automatic, [&](int j, const double* row) {
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
