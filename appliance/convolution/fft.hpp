// Fast Fourier transforms of power-of-two length in double precision: complex in place, and real input.
#pragma once

#include <complex>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace glint::convolution {

// True for 1, 2, 4, 8, ...: the lengths FftPlan and RealFftPlan accept.
bool is_fft_length(std::size_t n);

// Iterative radix-2 transform of one length (the batched form takes two stages per pass); the plan holds the twiddles and the bit-reversal permutation,
// so one plan serves any number of transforms, from any number of threads at once (it is not modified).
// Neither direction is scaled: inverse(forward(x)) = n x.
class FftPlan {
public:
    // Largest length accepted (2^30): indices stay within 32 bits.
    static constexpr std::size_t kMaxLength = std::size_t(1) << 30;

    explicit FftPlan(std::size_t n);  // throws InputError unless is_fft_length(n) and n <= kMaxLength
    std::size_t size() const { return n_; }

    // data[k] <- sum_j data[j] e^(-2 pi i j k / n), in place.
    void forward(std::complex<double>* data) const;
    // data[j] <- sum_k data[k] e^(+2 pi i j k / n), in place.
    void inverse(std::complex<double>* data) const;
    // forward() of kBatch sequences at once, one per vector lane, stored in bit-reversed order: value j
    // of lane b is re[reversed(j) * kBatch + b] + i im[reversed(j) * kBatch + b] (n * kBatch doubles
    // each), transformed in place into natural order. The same sums as forward() (its fused first two
    // stages multiply by exactly 1 and -i here), so each lane's result is forward()'s to rounding.
    static constexpr std::size_t kBatch = 8;
    void forward_batch_reversed(double* re, double* im) const;
    // The same with B = 4 or 8 lanes (re and im hold n * B doubles each); defined for those two.
    template <std::size_t B>
    void forward_lanes_reversed(double* re, double* im) const;
    // The bit-reversed position of index i < size().
    std::size_t reversed(std::size_t i) const { return reversed_[i]; }

private:
    std::size_t n_;
    // Stage of span 2h (h = 1, 2, 4, ..., n/2) uses e^(-2 pi i k / 2h) for k < h, stored at [h + k]: each
    // stage reads its twiddles contiguously.
    std::vector<double> twiddle_re_, twiddle_im_;
    std::vector<std::uint32_t> reversed_;  // bit-reversed index of each position
    void transform(std::complex<double>* data, bool inverse) const;
};

// Transform of n real values through one complex transform of length n/2 (the even samples as real
// parts, the odd ones as imaginary parts), unscaled like FftPlan. A real signal has a conjugate-symmetric
// spectrum, X[n-k] = conj(X[k]), so only X[0..n/2] (n/2 + 1 values) are produced or consumed.
class RealFftPlan {
public:
    explicit RealFftPlan(std::size_t n);  // throws InputError unless is_fft_length(n) and n <= 2^30
    std::size_t size() const { return n_; }
    // Number of spectrum values forward writes and inverse reads: n/2 + 1.
    std::size_t spectrum_size() const { return n_ / 2 + 1; }

    // spectrum[k] = sum_j x[j] e^(-2 pi i j k / n) for k in [0, n/2].
    void forward(const double* x, std::complex<double>* spectrum) const;
    // forward() of up to FftPlan::kBatch float signals at once (vector lanes, several times faster than
    // one by one): signal b < count read from x[b] (n values), its spectrum written as real parts to
    // re[b][0..n/2] and imaginary parts to im[b][0..n/2].
    void forward_batch(const float* const* x, double* const* re, double* const* im, std::size_t count) const;
    // x[j] = sum_{k<n} X[k] e^(+2 pi i j k / n) with X[k] = spectrum[k] for k <= n/2 and conj(spectrum[n-k])
    // above; the imaginary parts of spectrum[0] and spectrum[n/2] are ignored. spectrum is overwritten
    // (it is the work space).
    void inverse(std::complex<double>* spectrum, double* x) const;
    // inverse() of up to FftPlan::kBatch spectra at once, one per vector lane (the three channels
    // of a row: several times faster than one by one). spectra[b] (n/2 + 1 values) is read, not
    // changed; x[b] (n values) written, for b < count. Each result is inverse()'s to rounding.
    void inverse_batch(const std::complex<double>* const* spectra, double* const* x, std::size_t count) const;

private:
    std::size_t n_;
    FftPlan half_;                      // length max(n/2, 1)
    std::vector<double> w_re_, w_im_;   // e^(-2 pi i k / n) for k in [0, n/4]
    // inverse_batch() in vectors of B lanes (4 for up to four spectra, else 8); n > 1.
    template <std::size_t B>
    void inverse_lanes(const std::complex<double>* const* spectra, double* const* x, std::size_t count) const;
};

}  // namespace glint::convolution
