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

// FftPlan::kBatch doubles as one value the compiler keeps in registers (GCC/Clang vector extension).
using Lanes = double __attribute__((vector_size(FftPlan::kBatch * sizeof(double))));

inline Lanes load_lanes(const double* p) {
    Lanes v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline void store_lanes(double* p, Lanes v) { std::memcpy(p, &v, sizeof v); }

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

}  // namespace

void FftPlan::forward_batch_reversed(double* re, double* im) const {
    constexpr std::size_t B = kBatch;
    const std::size_t n = n_;
    // The radix-2 stages of transform(), each twiddle applied to all lanes; the first two stages are
    // radix-2 here too (twiddles 1 and -i, exact, so the sums are transform()'s).
    for (std::size_t h = 1; h < n; h *= 2) {
        const double* wr = twiddle_re_.data() + h;
        const double* wi = twiddle_im_.data() + h;
        for (std::size_t start = 0; start < n; start += 2 * h)
            for (std::size_t k = 0; k < h; ++k) {
                double* ar_p = re + (start + k) * B;
                double* ai_p = im + (start + k) * B;
                double* br_p = re + (start + h + k) * B;
                double* bi_p = im + (start + h + k) * B;
                const double c = wr[k], s = wi[k];
                const Lanes br = load_lanes(br_p), bi = load_lanes(bi_p);
                const Lanes tr = br * c - bi * s;
                const Lanes ti = br * s + bi * c;
                const Lanes ar = load_lanes(ar_p), ai = load_lanes(ai_p);
                store_lanes(br_p, ar - tr);
                store_lanes(bi_p, ai - ti);
                store_lanes(ar_p, ar + tr);
                store_lanes(ai_p, ai + ti);
            }
    }
}

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
            store_lanes(zr.data() + r, even[t]);
            store_lanes(zi.data() + r, odd[t]);
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
        store_lanes(xr.data() + k * B, vr);
        store_lanes(xi.data() + k * B, vi);
    };
    {
        const Lanes z0r = load_lanes(zr.data()), z0i = load_lanes(zi.data());
        const Lanes zero = {};
        put(0, z0r + z0i, zero);
        put(h, z0r - z0i, zero);
    }
    for (std::size_t k = 1; 2 * k <= h; ++k) {
        const std::size_t q = h - k;
        const Lanes pr = load_lanes(zr.data() + k * B), pi = load_lanes(zi.data() + k * B);
        const Lanes qr = load_lanes(zr.data() + q * B), qi = -load_lanes(zi.data() + q * B);
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
            vr[t] = load_lanes(xr.data() + (k0 + t) * B);
            vi[t] = load_lanes(xi.data() + (k0 + t) * B);
        }
        transpose8(vr);
        transpose8(vi);
        for (std::size_t b = 0; b < count; ++b) {
            store_lanes(re[b] + k0, vr[b]);
            store_lanes(im[b] + k0, vi[b]);
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
    const std::size_t h = n_ / 2;
    // Value k of every spectrum (lanes past count 0).
    const auto lanes_at = [&](std::size_t k, Lanes& re, Lanes& im) {
        double lr[B] = {}, li[B] = {};
        for (std::size_t b = 0; b < count; ++b) {
            lr[b] = spectra[b][k].real();
            li[b] = spectra[b][k].imag();
        }
        re = load_lanes(lr);
        im = load_lanes(li);
    };
    // inverse()'s packing into Z of length h, lane by lane; stored conjugated and in bit-reversed
    // order, since the inverse transform is the conjugate of the forward one of the conjugate.
    thread_local std::vector<double> zr, zi;
    zr.resize(h * B);
    zi.resize(h * B);
    const auto put = [&](std::size_t k, Lanes vr, Lanes vi) {
        const std::size_t r = half_.reversed(k) * B;
        store_lanes(zr.data() + r, vr);
        store_lanes(zi.data() + r, -vi);
    };
    {
        Lanes a0r, a0i, ahr, ahi;
        lanes_at(0, a0r, a0i);
        lanes_at(h, ahr, ahi);
        put(0, a0r + ahr, a0r - ahr);
    }
    for (std::size_t k = 1; 2 * k <= h; ++k) {
        const std::size_t q = h - k;
        Lanes ar, ai, br, bi;
        lanes_at(k, ar, ai);
        lanes_at(q, br, bi);
        bi = -bi;
        const Lanes sr = ar + br, si = ai + bi, dr = ar - br, di = ai - bi;
        const double wr = w_re_[k], wi = w_im_[k];
        const Lanes u = dr * wr + di * wi, v = di * wr - dr * wi;  // D conj(w^k) = u + i v
        put(k, sr - v, si + u);
        put(q, sr + v, u - si);  // for k = q (k = h/2) this one stands, as in inverse()
    }
    half_.forward_batch_reversed(zr.data(), zi.data());
    for (std::size_t j = 0; j < h; ++j) {
        double lr[B], li[B];
        store_lanes(lr, load_lanes(zr.data() + j * B));
        store_lanes(li, -load_lanes(zi.data() + j * B));
        for (std::size_t b = 0; b < count; ++b) {
            x[b][2 * j] = lr[b];
            x[b][2 * j + 1] = li[b];
        }
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
