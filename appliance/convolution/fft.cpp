// Radix-2 FFT plans: twiddles and bit reversal computed once, butterflies in real arithmetic.
#include "appliance/convolution/fft.hpp"

#include <bit>
#include <cmath>
#include <cstring>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "appliance/core/errors.hpp"

namespace glint::convolution {

namespace {

std::size_t checked_length(std::size_t n) {
    if (!is_fft_length(n) || n > FftPlan::kMaxLength)
        throw InputError("FFT length " + std::to_string(n) + " is not a power of two in [1, 2^30]");
    return n;
}

// e^(-2 pi i k / n). The angle is reduced to the first octant in integers and the result rebuilt by
// exact symmetries, so roots that are symmetric images of each other are bitwise images too, and the
// quarter turns are exactly 0 and +-1 (the real-input unpacking relies on w^(n/4) = -i).
void unit_root(std::size_t k, std::size_t n, double& re, double& im) {
    const unsigned long long t = k % n;
    const unsigned long long quadrant = 4 * t / n;
    unsigned long long rest = 4 * t - quadrant * n;  // angle within the quadrant, in units of (pi/2) / n
    bool swapped = false;
    if (2 * rest > n) {  // second octant of the quadrant: cos(a) = sin(pi/2 - a)
        rest = n - rest;
        swapped = true;
    }
    const double angle = (std::numbers::pi / 2) * static_cast<double>(rest) / static_cast<double>(n);
    double c = std::cos(angle), s = std::sin(angle);
    if (swapped) std::swap(c, s);
    // Rotate by `quadrant` quarter turns: (c, s) -> (-s, c).
    for (unsigned long long q = 0; q < quadrant; ++q) {
        const double c_next = -s;
        s = c;
        c = c_next;
    }
    re = c;
    im = -s;  // the forward kernel turns clockwise
}

}  // namespace

bool is_fft_length(std::size_t n) { return std::has_single_bit(n); }

FftPlan::FftPlan(std::size_t n) : n_(checked_length(n)) {
    twiddle_re_.assign(n_, 0.0);
    twiddle_im_.assign(n_, 0.0);
    for (std::size_t h = 1; h < n_; h *= 2)
        for (std::size_t k = 0; k < h; ++k) unit_root(k, 2 * h, twiddle_re_[h + k], twiddle_im_[h + k]);
    reversed_.assign(n_, 0);
    const int bits = std::countr_zero(n_);
    for (std::size_t i = 1; i < n_; ++i)  // reverse(i) from reverse(i / 2), shifted, plus i's low bit on top
        reversed_[i] = static_cast<std::uint32_t>((reversed_[i / 2] >> 1) | ((i & 1) << (bits - 1)));
}

void FftPlan::forward(std::complex<double>* data) const { transform(data, false); }

void FftPlan::inverse(std::complex<double>* data) const { transform(data, true); }

void FftPlan::transform(std::complex<double>* data, bool inverse) const {
    const std::size_t n = n_;
    for (std::size_t i = 0; i < n; ++i) {
        const std::size_t r = reversed_[i];
        if (i < r) std::swap(data[i], data[r]);
    }
    // [complex.numbers] allows an array of complex<double> to be read as interleaved doubles. The products
    // are written out because std::complex's operator* checks for NaN and calls into libgcc.
    double* d = reinterpret_cast<double*>(data);
    const double sign = inverse ? -1.0 : 1.0;  // the inverse uses the conjugate twiddles
    std::size_t first_h = 1;
    if (n >= 4) {
        // The first two stages (twiddles 1 and -+i) fused into radix-4 butterflies without
        // multiplications: the same sums as the radix-2 stages, without their short inner loops.
        for (std::size_t g = 0; g < n; g += 4) {
            double* x = d + 2 * g;
            const double a0r = x[0] + x[2], a0i = x[1] + x[3];
            const double a1r = x[0] - x[2], a1i = x[1] - x[3];
            const double a2r = x[4] + x[6], a2i = x[5] + x[7];
            const double a3r = x[4] - x[6], a3i = x[5] - x[7];
            // t = a3 * w with w = -i (forward) or +i (inverse)
            const double tr = sign * a3i, ti = -sign * a3r;
            x[0] = a0r + a2r;
            x[1] = a0i + a2i;
            x[4] = a0r - a2r;
            x[5] = a0i - a2i;
            x[2] = a1r + tr;
            x[3] = a1i + ti;
            x[6] = a1r - tr;
            x[7] = a1i - ti;
        }
        first_h = 4;
    }
    for (std::size_t h = first_h; h < n; h *= 2) {
        const double* wr = twiddle_re_.data() + h;
        const double* wi = twiddle_im_.data() + h;
        for (std::size_t start = 0; start < n; start += 2 * h) {
            double* a = d + 2 * start;
            double* b = d + 2 * (start + h);
            for (std::size_t k = 0; k < h; ++k) {
                const double c = wr[k], s = sign * wi[k];
                const double br = b[2 * k], bi = b[2 * k + 1];
                const double tr = br * c - bi * s;
                const double ti = br * s + bi * c;
                const double ar = a[2 * k], ai = a[2 * k + 1];
                b[2 * k] = ar - tr;
                b[2 * k + 1] = ai - ti;
                a[2 * k] = ar + tr;
                a[2 * k + 1] = ai + ti;
            }
        }
    }
}

namespace {

// B doubles as one value the compiler keeps in registers (GCC/Clang vector extension). kBatch
// (one zmm register) serve full batches; four (one ymm) serve the three channels of a row, where
// eight lanes would spend five of them on zeros (and a 512-bit operation costs two 256-bit ones
// on some cores, Zen 4 among them).
// (Spelled out per width: GCC drops a vector_size that depends on a template parameter.)
template <std::size_t B>
struct VectorOf;
template <>
struct VectorOf<4> {
    using type = double __attribute__((vector_size(4 * sizeof(double))));
};
template <>
struct VectorOf<8> {
    using type = double __attribute__((vector_size(8 * sizeof(double))));
};
template <std::size_t B>
using LanesOf = typename VectorOf<B>::type;

template <std::size_t B>
inline LanesOf<B> load_b(const double* p) {
    LanesOf<B> v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
template <std::size_t B>
inline void store_b(double* p, LanesOf<B> v) {
    std::memcpy(p, &v, sizeof v);
}

using Lanes = LanesOf<FftPlan::kBatch>;

static_assert(FftPlan::kBatch == 8, "transpose8 moves 8 x 8 blocks");

// Rows v[0..7] of an 8 x 8 block become its columns: v[t][b] <- v[b][t]. Three stages of
// shuffles that swap ever larger sub-blocks, instead of 64 scalar loads and stores.
inline void transpose8(Lanes v[8]) {
    Lanes s[8], u[8];
    for (int i = 0; i < 8; i += 2) {
        s[i] = __builtin_shufflevector(v[i], v[i + 1], 0, 8, 2, 10, 4, 12, 6, 14);
        s[i + 1] = __builtin_shufflevector(v[i], v[i + 1], 1, 9, 3, 11, 5, 13, 7, 15);
    }
    for (int i : {0, 1, 4, 5}) {
        u[i] = __builtin_shufflevector(s[i], s[i + 2], 0, 1, 8, 9, 4, 5, 12, 13);
        u[i + 2] = __builtin_shufflevector(s[i], s[i + 2], 2, 3, 10, 11, 6, 7, 14, 15);
    }
    for (int i = 0; i < 4; ++i) {
        v[i] = __builtin_shufflevector(u[i], u[i + 4], 0, 1, 2, 3, 8, 9, 10, 11);
        v[i + 4] = __builtin_shufflevector(u[i], u[i + 4], 4, 5, 6, 7, 12, 13, 14, 15);
    }
}

// One complex value per lane.
template <std::size_t B>
struct ComplexLanes {
    LanesOf<B> re, im;
};

template <std::size_t B>
inline ComplexLanes<B> load_value(const double* re, const double* im, std::size_t i) {
    return {load_b<B>(re + i * B), load_b<B>(im + i * B)};
}
template <std::size_t B>
inline void store_value(double* re, double* im, std::size_t i, ComplexLanes<B> v) {
    store_b<B>(re + i * B, v.re);
    store_b<B>(im + i * B, v.im);
}

// One radix-2 butterfly in registers: (a, b) <- (a + w b, a - w b), w = c + i s.
template <std::size_t B>
inline void butterfly(ComplexLanes<B>& a, ComplexLanes<B>& b, double c, double s) {
    const LanesOf<B> tr = b.re * c - b.im * s;
    const LanesOf<B> ti = b.re * s + b.im * c;
    b = {a.re - tr, a.im - ti};
    a = {a.re + tr, a.im + ti};
}

// Rows v[0..3] of a 4 x 4 block become its columns.
inline void transpose4(LanesOf<4> v[4]) {
    const LanesOf<4> s0 = __builtin_shufflevector(v[0], v[1], 0, 4, 2, 6);
    const LanesOf<4> s1 = __builtin_shufflevector(v[0], v[1], 1, 5, 3, 7);
    const LanesOf<4> s2 = __builtin_shufflevector(v[2], v[3], 0, 4, 2, 6);
    const LanesOf<4> s3 = __builtin_shufflevector(v[2], v[3], 1, 5, 3, 7);
    v[0] = __builtin_shufflevector(s0, s2, 0, 1, 4, 5);
    v[1] = __builtin_shufflevector(s1, s3, 0, 1, 4, 5);
    v[2] = __builtin_shufflevector(s0, s2, 2, 3, 6, 7);
    v[3] = __builtin_shufflevector(s1, s3, 2, 3, 6, 7);
}

template <std::size_t B>
inline void transpose(LanesOf<B> v[B]) {
    if constexpr (B == 4)
        transpose4(v);
    else
        transpose8(v);
}

// B complex values stored as (re, im) pairs at p, split into their real and imaginary parts.
template <std::size_t B>
inline void split_complex(const double* p, LanesOf<B>& re, LanesOf<B>& im) {
    const LanesOf<B> a = load_b<B>(p), b = load_b<B>(p + B);
    if constexpr (B == 4) {
        re = __builtin_shufflevector(a, b, 0, 2, 4, 6);
        im = __builtin_shufflevector(a, b, 1, 3, 5, 7);
    } else {
        re = __builtin_shufflevector(a, b, 0, 2, 4, 6, 8, 10, 12, 14);
        im = __builtin_shufflevector(a, b, 1, 3, 5, 7, 9, 11, 13, 15);
    }
}

// The inverse: re and im interleaved into 2 B values at p (re[0], im[0], re[1], ...).
template <std::size_t B>
inline void join_complex(double* p, LanesOf<B> re, LanesOf<B> im) {
    if constexpr (B == 4) {
        store_b<B>(p, __builtin_shufflevector(re, im, 0, 4, 1, 5));
        store_b<B>(p + B, __builtin_shufflevector(re, im, 2, 6, 3, 7));
    } else {
        store_b<B>(p, __builtin_shufflevector(re, im, 0, 8, 1, 9, 2, 10, 3, 11));
        store_b<B>(p + B, __builtin_shufflevector(re, im, 4, 12, 5, 13, 6, 14, 7, 15));
    }
}

}  // namespace

template <std::size_t B>
void FftPlan::forward_lanes_reversed(double* re, double* im) const {
    static_assert(B == 4 || B == 8, "four or eight lanes");
    const std::size_t n = n_;
    // The radix-2 stages of transform(), each twiddle applied to all lanes, taken two stages per
    // pass over the data: stages h and 2h touch the same four values (k, k + h, k + 2h, k + 3h of
    // a block of 4h), so each value is loaded and stored once for both. Every value goes through
    // exactly the radix-2 operations, in their order, so the sums are those of one stage per pass
    // (and transform()'s: its fused first two stages multiply by exactly 1 and -i here).
    std::size_t h = 1;
    for (; 4 * h <= n; h *= 4) {
        const double* w1r = twiddle_re_.data() + h;
        const double* w1i = twiddle_im_.data() + h;
        const double* w2r = twiddle_re_.data() + 2 * h;
        const double* w2i = twiddle_im_.data() + 2 * h;
        for (std::size_t start = 0; start < n; start += 4 * h)
            for (std::size_t k = 0; k < h; ++k) {
                const std::size_t p0 = start + k, p1 = p0 + h, p2 = p0 + 2 * h, p3 = p0 + 3 * h;
                ComplexLanes<B> v0 = load_value<B>(re, im, p0), v1 = load_value<B>(re, im, p1);
                ComplexLanes<B> v2 = load_value<B>(re, im, p2), v3 = load_value<B>(re, im, p3);
                butterfly<B>(v0, v1, w1r[k], w1i[k]);
                butterfly<B>(v2, v3, w1r[k], w1i[k]);
                butterfly<B>(v0, v2, w2r[k], w2i[k]);
                butterfly<B>(v1, v3, w2r[h + k], w2i[h + k]);
                store_value<B>(re, im, p0, v0);
                store_value<B>(re, im, p1, v1);
                store_value<B>(re, im, p2, v2);
                store_value<B>(re, im, p3, v3);
            }
    }
    if (2 * h <= n) {  // an odd number of stages: the last alone
        const double* wr = twiddle_re_.data() + h;
        const double* wi = twiddle_im_.data() + h;
        for (std::size_t k = 0; k < h; ++k) {
            ComplexLanes<B> a = load_value<B>(re, im, k), b = load_value<B>(re, im, k + h);
            butterfly<B>(a, b, wr[k], wi[k]);
            store_value<B>(re, im, k, a);
            store_value<B>(re, im, k + h, b);
        }
    }
}

template void FftPlan::forward_lanes_reversed<4>(double*, double*) const;
template void FftPlan::forward_lanes_reversed<8>(double*, double*) const;

void FftPlan::forward_batch_reversed(double* re, double* im) const { forward_lanes_reversed<kBatch>(re, im); }

RealFftPlan::RealFftPlan(std::size_t n) : n_(checked_length(n)), half_(n_ > 1 ? n_ / 2 : 1) {
    const std::size_t count = n_ / 4 + 1;
    w_re_.assign(count, 0.0);
    w_im_.assign(count, 0.0);
    for (std::size_t k = 0; k < count; ++k) unit_root(k, n_, w_re_[k], w_im_[k]);
}

void RealFftPlan::forward(const double* x, std::complex<double>* spectrum) const {
    if (n_ == 1) {
        spectrum[0] = {x[0], 0.0};
        return;
    }
    const std::size_t h = n_ / 2;
    for (std::size_t j = 0; j < h; ++j) spectrum[j] = {x[2 * j], x[2 * j + 1]};
    half_.forward(spectrum);
    // Z = FFT_h(even + i odd) holds E = FFT_h(even) and O = FFT_h(odd):
    //   E_k = (Z_k + conj Z_{h-k}) / 2,  O_k = (Z_k - conj Z_{h-k}) / 2i,  X_k = E_k + w^k O_k,
    // and X_{h-k} = conj(E_k - w^k O_k). Pairs (k, h-k) are unpacked together, in place.
    const double z0r = spectrum[0].real(), z0i = spectrum[0].imag();
    spectrum[0] = {z0r + z0i, 0.0};
    spectrum[h] = {z0r - z0i, 0.0};
    for (std::size_t k = 1; 2 * k <= h; ++k) {
        const std::size_t q = h - k;
        const double pr = spectrum[k].real(), pi = spectrum[k].imag();
        const double qr = spectrum[q].real(), qi = -spectrum[q].imag();  // conj Z_{h-k}
        const double er = 0.5 * (pr + qr), ei = 0.5 * (pi + qi);
        const double orr = 0.5 * (pi - qi), oi = -0.5 * (pr - qr);
        const double wr = w_re_[k], wi = w_im_[k];
        const double tr = wr * orr - wi * oi, ti = wr * oi + wi * orr;
        spectrum[k] = {er + tr, ei + ti};
        spectrum[q] = {er - tr, ti - ei};
    }
}

void RealFftPlan::forward_batch(const float* const* x, double* const* re, double* const* im,
                                std::size_t count) const {
    constexpr std::size_t B = FftPlan::kBatch;
    if (count > B) throw InputError("RealFftPlan::forward_batch: at most " + std::to_string(B) + " signals");
    if (n_ == 1) {
        for (std::size_t b = 0; b < count; ++b) {
            re[b][0] = double(x[b][0]);
            im[b][0] = 0.0;
        }
        return;
    }
    const std::size_t h = n_ / 2;
    // Lane-interleaved work arrays, per thread (reused: written whole before they are read).
    thread_local std::vector<double> zr, zi;
    zr.resize(h * B);
    zi.resize(h * B);
    // Stored straight into bit-reversed order (the transform's first step). Eight values of each
    // signal at a time: even and odd samples split, then the 8 x 8 block turned so that each
    // vector holds one sample of every signal (signals past count are zeros).
    using Floats = float __attribute__((vector_size(2 * B * sizeof(float))));
    std::size_t j0 = 0;
    for (; j0 + B <= h; j0 += B) {
        Lanes even[B], odd[B];
        for (std::size_t b = 0; b < B; ++b) {
            if (b >= count) {
                even[b] = Lanes{};
                odd[b] = Lanes{};
                continue;
            }
            Floats f;
            std::memcpy(&f, x[b] + 2 * j0, sizeof f);
            even[b] = __builtin_convertvector(__builtin_shufflevector(f, f, 0, 2, 4, 6, 8, 10, 12, 14), Lanes);
            odd[b] = __builtin_convertvector(__builtin_shufflevector(f, f, 1, 3, 5, 7, 9, 11, 13, 15), Lanes);
        }
        transpose8(even);
        transpose8(odd);
        for (std::size_t t = 0; t < B; ++t) {
            const std::size_t r = half_.reversed(j0 + t) * B;
            store_b<B>(zr.data() + r, even[t]);
            store_b<B>(zi.data() + r, odd[t]);
        }
    }
    for (std::size_t j = j0; j < h; ++j) {  // lengths below 2 B
        const std::size_t r = half_.reversed(j) * B;
        for (std::size_t b = 0; b < B; ++b) {
            zr[r + b] = b < count ? double(x[b][2 * j]) : 0.0;
            zi[r + b] = b < count ? double(x[b][2 * j + 1]) : 0.0;
        }
    }
    half_.forward_batch_reversed(zr.data(), zi.data());
    // forward()'s unpacking, lane by lane, into lane-interleaved spectra (each pair (k, h-k) read
    // before it is written); then turned 8 x 8 into each signal's own arrays.
    thread_local std::vector<double> xr, xi;
    xr.resize((h + 1) * B);
    xi.resize((h + 1) * B);
    const auto put = [&](std::size_t k, Lanes vr, Lanes vi) {
        store_b<B>(xr.data() + k * B, vr);
        store_b<B>(xi.data() + k * B, vi);
    };
    {
        const Lanes z0r = load_b<B>(zr.data()), z0i = load_b<B>(zi.data());
        const Lanes zero = {};
        put(0, z0r + z0i, zero);
        put(h, z0r - z0i, zero);
    }
    for (std::size_t k = 1; 2 * k <= h; ++k) {
        const std::size_t q = h - k;
        const Lanes pr = load_b<B>(zr.data() + k * B), pi = load_b<B>(zi.data() + k * B);
        const Lanes qr = load_b<B>(zr.data() + q * B), qi = -load_b<B>(zi.data() + q * B);
        const Lanes er = 0.5 * (pr + qr), ei = 0.5 * (pi + qi);
        const Lanes orr = 0.5 * (pi - qi), oi = -0.5 * (pr - qr);
        const double wr = w_re_[k], wi = w_im_[k];
        const Lanes tr = wr * orr - wi * oi, ti = wr * oi + wi * orr;
        put(k, er + tr, ei + ti);
        put(q, er - tr, ti - ei);
    }
    std::size_t k0 = 0;
    for (; k0 + B <= h + 1; k0 += B) {
        Lanes vr[B], vi[B];
        for (std::size_t t = 0; t < B; ++t) {
            vr[t] = load_b<B>(xr.data() + (k0 + t) * B);
            vi[t] = load_b<B>(xi.data() + (k0 + t) * B);
        }
        transpose8(vr);
        transpose8(vi);
        for (std::size_t b = 0; b < count; ++b) {
            store_b<B>(re[b] + k0, vr[b]);
            store_b<B>(im[b] + k0, vi[b]);
        }
    }
    for (std::size_t k = k0; k <= h; ++k)
        for (std::size_t b = 0; b < count; ++b) {
            re[b][k] = xr[k * B + b];
            im[b][k] = xi[k * B + b];
        }
}

void RealFftPlan::inverse_batch(const std::complex<double>* const* spectra, double* const* x,
                                std::size_t count) const {
    constexpr std::size_t B = FftPlan::kBatch;
    if (count > B) throw InputError("RealFftPlan::inverse_batch: at most " + std::to_string(B) + " spectra");
    if (n_ == 1) {
        for (std::size_t b = 0; b < count; ++b) x[b][0] = spectra[b][0].real();
        return;
    }
    if (count <= 4)
        inverse_lanes<4>(spectra, x, count);
    else
        inverse_lanes<B>(spectra, x, count);
}

template <std::size_t B>
void RealFftPlan::inverse_lanes(const std::complex<double>* const* spectra, double* const* x,
                                std::size_t count) const {
    using V = LanesOf<B>;
    const std::size_t h = n_ / 2;
    // The spectra turned into lane-interleaved arrays (value k of spectrum b at k * B + b; lanes
    // past count 0), B values of each at a time through a B x B transpose, so that the packing
    // below reads whole vectors. std::complex<double> is two doubles, real part first.
    thread_local std::vector<double> in_re, in_im;
    in_re.resize((h + 1) * B);
    in_im.resize((h + 1) * B);
    std::size_t k0 = 0;
    for (; k0 + B <= h + 1; k0 += B) {
        V vr[B], vi[B];
        for (std::size_t b = 0; b < B; ++b) {
            if (b < count) {
                split_complex<B>(reinterpret_cast<const double*>(spectra[b] + k0), vr[b], vi[b]);
            } else {
                vr[b] = V{};
                vi[b] = V{};
            }
        }
        transpose<B>(vr);
        transpose<B>(vi);
        for (std::size_t t = 0; t < B; ++t) {
            store_b<B>(in_re.data() + (k0 + t) * B, vr[t]);
            store_b<B>(in_im.data() + (k0 + t) * B, vi[t]);
        }
    }
    for (std::size_t k = k0; k <= h; ++k)
        for (std::size_t b = 0; b < B; ++b) {
            in_re[k * B + b] = b < count ? spectra[b][k].real() : 0.0;
            in_im[k * B + b] = b < count ? spectra[b][k].imag() : 0.0;
        }
    const auto lanes_at = [&](std::size_t k, V& re, V& im) {
        re = load_b<B>(in_re.data() + k * B);
        im = load_b<B>(in_im.data() + k * B);
    };
    // inverse()'s packing into Z of length h, lane by lane; stored conjugated and in bit-reversed
    // order, since the inverse transform is the conjugate of the forward one of the conjugate.
    thread_local std::vector<double> zr, zi;
    zr.resize(h * B);
    zi.resize(h * B);
    const auto put = [&](std::size_t k, V vr, V vi) {
        const std::size_t r = half_.reversed(k) * B;
        store_b<B>(zr.data() + r, vr);
        store_b<B>(zi.data() + r, -vi);
    };
    {
        V a0r, a0i, ahr, ahi;
        lanes_at(0, a0r, a0i);
        lanes_at(h, ahr, ahi);
        put(0, a0r + ahr, a0r - ahr);
    }
    for (std::size_t k = 1; 2 * k <= h; ++k) {
        const std::size_t q = h - k;
        V ar, ai, br, bi;
        lanes_at(k, ar, ai);
        lanes_at(q, br, bi);
        bi = -bi;
        const V sr = ar + br, si = ai + bi, dr = ar - br, di = ai - bi;
        const double wr = w_re_[k], wi = w_im_[k];
        const V u = dr * wr + di * wi, v = di * wr - dr * wi;  // D conj(w^k) = u + i v
        put(k, sr - v, si + u);
        put(q, sr + v, u - si);  // for k = q (k = h/2) this one stands, as in inverse()
    }
    half_.forward_lanes_reversed<B>(zr.data(), zi.data());
    // Out of the lanes: x_{2j} + i x_{2j+1} is the conjugate of Z's value j; B values of j at a
    // time turned B x B, each signal's written as 2 B consecutive doubles.
    std::size_t j0 = 0;
    for (; j0 + B <= h; j0 += B) {
        V vr[B], vi[B];
        for (std::size_t t = 0; t < B; ++t) {
            vr[t] = load_b<B>(zr.data() + (j0 + t) * B);
            vi[t] = -load_b<B>(zi.data() + (j0 + t) * B);
        }
        transpose<B>(vr);
        transpose<B>(vi);
        for (std::size_t b = 0; b < count; ++b) join_complex<B>(x[b] + 2 * j0, vr[b], vi[b]);
    }
    for (std::size_t j = j0; j < h; ++j)
        for (std::size_t b = 0; b < count; ++b) {
            x[b][2 * j] = zr[j * B + b];
            x[b][2 * j + 1] = -zi[j * B + b];
        }
}

void RealFftPlan::inverse(std::complex<double>* spectrum, double* x) const {
    if (n_ == 1) {
        x[0] = spectrum[0].real();
        return;
    }
    const std::size_t h = n_ / 2;
    // The reverse of forward's unpacking: with A = X_k, B = conj X_{h-k}, S = A + B, D = A - B,
    //   Z_k = S + i D conj(w^k),  Z_{h-k} = conj S + i conj(D conj(w^k)),
    // and the inverse of length h of Z gives x_{2j} + i x_{2j+1} (both sides unscaled).
    const double a0 = spectrum[0].real(), ah = spectrum[h].real();
    spectrum[0] = {a0 + ah, a0 - ah};
    for (std::size_t k = 1; 2 * k <= h; ++k) {
        const std::size_t q = h - k;
        const double ar = spectrum[k].real(), ai = spectrum[k].imag();
        const double br = spectrum[q].real(), bi = -spectrum[q].imag();
        const double sr = ar + br, si = ai + bi, dr = ar - br, di = ai - bi;
        const double wr = w_re_[k], wi = w_im_[k];
        const double u = dr * wr + di * wi, v = di * wr - dr * wi;  // D conj(w^k) = u + i v
        spectrum[k] = {sr - v, si + u};
        spectrum[q] = {sr + v, u - si};
    }
    half_.inverse(spectrum);
    for (std::size_t j = 0; j < h; ++j) {
        x[2 * j] = spectrum[j].real();
        x[2 * j + 1] = spectrum[j].imag();
    }
}

}  // namespace glint::convolution
