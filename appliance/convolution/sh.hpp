// Real spherical harmonics: basis, separable projection of an equirect map, Phong kernel, reconstruction.
//
// Angles are those of docs/conventions.md: theta = polar angle from +Y, phi = the equirect azimuth, so
//   d = ( sin(theta) sin(phi), cos(theta), -sin(theta) cos(phi) ).
// Real orthonormal SH, index l*(l+1)+m, no Condon-Shortley phase:
//   Y_l0    =       \bar P_l0(cos theta)
//   Y_lm    = sqrt2 \bar P_lm(cos theta) cos(m phi)      m > 0
//   Y_l,-m  = sqrt2 \bar P_lm(cos theta) sin(m phi)      m > 0
// with \bar P_lm = N_lm P_lm, N_lm = sqrt((2l+1)/(4 pi) (l-m)!/(l+m)!), P_lm = (1-x^2)^(m/2) d^m/dx^m P_l.
// In this basis Y_1,-1 = sqrt(3/(4 pi)) x, Y_10 = sqrt(3/(4 pi)) y, Y_11 = -sqrt(3/(4 pi)) z.
// "order" is the number of bands (l = 0..order-1), as in the thesis; order*order coefficients.
#pragma once

#include <functional>
#include <span>
#include <vector>

#include "appliance/core/equirect.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::convolution {

// Largest order accepted (bands 0..kMaxShOrder-1); the recurrences are tested to order 512.
inline constexpr int kMaxShOrder = 2048;
// Largest number of bands phong_sh_kernel returns (a plain O(bands) recurrence).
inline constexpr int kMaxKernelBands = 1 << 20;

// Row weights of the projection quadrature.
//   TexelSolidAngle: the exact row solid angle of the conventions, the weights of the exact engine.
//   Fejer: Fejer's first rule in x = cos(theta) at the row centres, exact for band-limited input.
enum class ShQuadrature { TexelSolidAngle, Fejer };

struct ShCoefficients {
    int order = 0;
    std::vector<double> rgb;  // order*order*3, index (l*(l+1)+m)*3 + channel

    double& at(int l, int m, int channel) { return rgb[std::size_t((l * (l + 1) + m) * 3 + channel)]; }
    double at(int l, int m, int channel) const { return rgb[std::size_t((l * (l + 1) + m) * 3 + channel)]; }
};

// Packed index of \bar P_lm (0 <= m <= l) in the output of ShLegendre::evaluate.
inline int legendre_index(int l, int m) { return l * (l + 1) / 2 + m; }

// Fully normalised associated Legendre functions \bar P_lm(cos theta) for 0 <= m <= l < order by the
// standard stable recurrences (no factorials; Holmes & Featherstone 2002, J. Geodesy 76):
//   \bar P_00     = 1 / sqrt(4 pi)
//   \bar P_mm     = sqrt((2m+1)/(2m)) sin(theta) \bar P_m-1,m-1
//   \bar P_m+1,m  = sqrt(2m+3) cos(theta) \bar P_mm
//   \bar P_lm     = a_lm (cos(theta) \bar P_l-1,m - b_lm \bar P_l-2,m),
//   a_lm = sqrt((4l^2-1)/(l^2-m^2)),  b_lm = sqrt(((l-1)^2-m^2)/(4(l-1)^2-1)).
// The coefficients are computed once per order. A diagonal value that falls below kDiagonalFloor (only
// near the poles, where sin^m underflows) is set to 0 with every higher m: the functions so dropped are
// below 1e-180 for l < 512 (test_sh.cpp checks 1e-100 against long double), and no subnormal arithmetic
// is done. Near a pole x = cos(theta) itself fixes theta only to eps/theta, so values there can be off by
// up to about l eps/theta relative whatever the recurrence (4e-11 at l = 511, theta = pi/2048).
class ShLegendre {
public:
    static constexpr double kDiagonalFloor = 1e-280;

    explicit ShLegendre(int order);  // throws InputError unless 1 <= order <= kMaxShOrder
    int order() const { return order_; }

    // \bar P_mm(cos theta) for m in [0, order), given s = sin(theta) >= 0.
    void diagonal(double s, double* out) const;
    // Column m: out[l - m] = \bar P_lm(x) for l in [m, order), given x = cos(theta) and \bar P_mm.
    void column(int m, double x, double pmm, double* out) const;
    // Column 0 (the zonal functions): out[l] = \bar P_l0(x) for l in [0, order). \bar P_00 is a
    // constant, so no diagonal is needed.
    void zonal(double x, double* out) const;
    // All values, out[legendre_index(l, m)], order*(order+1)/2 of them.
    void evaluate(double x, double s, double* out) const;

private:
    int order_;
    std::vector<double> diag_;  // sqrt((2m+1)/(2m)) for m >= 1
    std::vector<double> a_;     // a_lm at column_offset(m) + l - m, for l >= m + 2
    std::vector<double> b_;
    std::size_t column_offset(int m) const { return std::size_t(m) * std::size_t(order_) - std::size_t(m) * std::size_t(m - 1) / 2; }
};

// The order*order basis values Y_lm(d) at index l*(l+1)+m. d need not be normalised; throws InputError
// if it is zero or not finite. The second form reuses the recurrence coefficients of legendre.order().
void sh_basis(int order, const glm::dvec3& d, double* out);
void sh_basis(const ShLegendre& legendre, const glm::dvec3& d, double* out);

// Per-row weights of Fejer's first rule in x = cos(theta) at theta_j = (j + 0.5) pi / H; they sum to 2.
std::vector<double> fejer_weights(int height);

// Solid-angle weight of one texel of row j (all texels of a row share it) under quadrature q.
std::vector<double> sh_row_weights(int width, int height, ShQuadrature q);

// c_lm = sum_texels w_row L Y_lm, separably: per row the azimuthal Fourier sums (by FFT for a power-of-two
// width, see ShAzimuthal), then the Legendre recurrence, once per pair of rows mirrored in the equator.
// The rows are summed in a fixed order with compensated sums, so the result does not depend on `threads`
// (<= 0: all hardware threads). Throws InputError on an empty map or a bad order.
// Plain summation drops the compensation (about 1.5x faster): for callers whose
// error budget is far above double rounding, like auto's SH split (bounded at
// 1e-6 tau relative, while plain sums of a few hundred rows are within ~1e-14).
enum class ShSummation { Compensated, Plain };
ShCoefficients sh_project(const HdrImage& env, int order, int threads,
                          ShQuadrature q = ShQuadrature::TexelSolidAngle,
                          ShSummation summation = ShSummation::Compensated);
// The same for radiance in double, interleaved RGB, row 0 at the top (width*height*3 values).
ShCoefficients sh_project(std::span<const double> rgb, int width, int height, int order, int threads,
                          ShQuadrature q = ShQuadrature::TexelSolidAngle);

// The same from the rows' spectra instead of their texels (the cone's Fourier first pass keeps
// them per level, fourier_pass.hpp): spectrum_of_row(j) gives row j's
//   X_c[k] = sum_i L_c,i e^(-2 pi i i k / W),  k in [0, W/2],
// per channel c its W/2 + 1 real parts, then its imaginary parts (6 (W/2 + 1) values). The width
// must be a power of two (InputError otherwise); the sums are those of the FFT path of sh_project.
// Rows are read in aligned runs of FftPlan::kBatch, each run by one thread (a source may make a
// run's spectra together).
using RowSpectrumSource = std::function<const double*(int row)>;
ShCoefficients sh_project_spectra(int width, int height, int order, int threads, const RowSpectrumSource& spectrum_of_row,
                                  ShQuadrature q = ShQuadrature::TexelSolidAngle,
                                  ShSummation summation = ShSummation::Compensated);

// Per band l: Lambda_l rho_l of thesis eq. 2.33 for the normalised Phong lobe (n+1)/(2 pi) max(0, cos)^n,
// i.e. (n+1) int_0^1 x^n P_l(x) dx, for l in [0, order). Throws InputError for n < 0, non-finite n or
// order outside [1, kMaxKernelBands].
std::vector<double> phong_sh_kernel(double n, int order);

// E(r) = sum_lm kernel[l] c_lm Y_lm(r) at every texel centre of a width x height equirect map, in double,
// interleaved RGB, not clamped. kernel needs c.order entries. threads <= 0: all hardware threads. Each row
// is synthesised from its azimuthal series by an inverse FFT for a power-of-two width (see ShAzimuthal).
std::vector<double> sh_evaluate(const ShCoefficients& c, const std::vector<double>& kernel, int width,
                                int height, int threads);

// sh_evaluate of the first `order` bands of c (order <= c.order), row by row: sink(j, values) gets the
// 3 * width interleaved values of row j, from worker threads, rows in any order.
void sh_evaluate_rows(const ShCoefficients& c, int order, const std::vector<double>& kernel, int width, int height,
                      int threads, const std::function<void(int, const double*)>& sink);

// The tables of sh_evaluate's recurrences, for another device (the GPU engine):
// for column m, a[t], b[t] with \bar P_{m+t,m} = a[t] (x \bar P_{m+t-1,m} - b[t] \bar P_{m+t-2,m})
// for t in [1, order - m) (b[1] = 0), and \bar P_mm(cos theta) from s = sin(theta).
void sh_column_steps(int order, int m, double* a, double* b);
void sh_diagonal(int order, double s, double* out);

// sh_evaluate as an image: negative channel values are clamped to 0 and counted in *clamped.
HdrImage sh_reconstruct(const ShCoefficients& c, const std::vector<double>& kernel, int width, int height,
                        int threads, long long* clamped = nullptr);

// How the separable paths sum over the columns of a row: by a real FFT (fft.hpp), O(W log W) per row, or
// directly, O(W order). Automatic takes the FFT when the width is a power of two and the order is high
// enough for it to be faster (12 bands for sh_project, 24 for sh_evaluate), the direct sums otherwise;
// the two agree to rounding (below 1e-14 relative). The forced forms below let tests compare the paths.
enum class ShAzimuthal { Automatic, Direct, Fft };

namespace detail {
// sh_project and sh_evaluate with the azimuthal path forced; ShAzimuthal::Fft throws InputError unless
// the width is a power of two.
ShCoefficients sh_project(std::span<const double> rgb, int width, int height, int order, int threads,
                          ShQuadrature q, ShAzimuthal azimuthal);
std::vector<double> sh_evaluate(const ShCoefficients& c, const std::vector<double>& kernel, int width,
                                int height, int threads, ShAzimuthal azimuthal);
}  // namespace detail

}  // namespace glint::convolution
