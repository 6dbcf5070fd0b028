// The cone's first pass by Fourier transforms along the rows (docs/convolution.md, "The
// Fourier first pass"): the same terms as LobeSummer::sum_row's first pass, summed as
// products of row spectra instead of one multiply-add per term and output texel.
//
// Why it is exact: a Phong weight depends on the output row, the level row and the azimuth
// offset only, so the terms one level row gives an output row are a circular correlation of
// that row with a short kernel (the weights of the cone's columns). One forward transform per
// level row and channel (shared by every output row), one product per (output row, level
// row) and spectrum bin, and one inverse transform per output row and channel give every
// output column at once. The kernel's spectrum is a cosine sum over its few columns (or its
// own transform when it is wide); nothing is cut or approximated beyond what the first pass
// itself keeps, and the sums are in double (rounding ~1e-15 of a row's energy).
//
// Cost per output row: (level rows in the cone) x (W/2 bins) x (kernel columns / 2 + 6)
// against (level rows) x (output columns) x (kernel columns) x 3 for the direct sums, so a
// narrow lobe whose cone spans tens of columns gains most.
#pragma once

#include <memory>
#include <vector>

#include "appliance/convolution/lobe_sum.hpp"
#include "appliance/convolution/methods.hpp"

namespace glint::convolution {

class FourierFirstPass {
public:
    // Whether the pass sums an output of this width from a level of this size: power-of-two
    // widths, the output's no wider than the level's (one column class: LobeSummer::classes()
    // is 1), and a level of at most kMaxLevelTexels (its spectra take twice the memory of its
    // float planes: 200 MB at 4096x2048, 800 MB at 8192x4096). 4096x2048 is what an 8192x4096
    // input's n = 20480 reads: there the peak grew from 605 to 751 MiB (the target is 1 GiB) and
    // the map took 1.12-1.15 s instead of 1.30-1.39 s (docs/convolution.md).
    static constexpr long long kMaxLevelTexels = 4096LL * 2048LL;
    static bool applies(int level_width, int level_height, int out_width);
    // Whether the cone uses it: it applies and the output has at least half the level's columns.
    // Its spectra cost three transforms per level row whatever the output, and its sums about
    // W/2 x (kernel columns / 2 + 6) per (output row, level row) against out_w x kernel columns
    // x 3 for the direct sums: measured on 1024x512 maps (docs/convolution.md), n = 5120 and
    // 20480 at 512x256 took 2x less time with it and at 128x64 2x more.
    static bool pays_off(int level_width, int level_height, int out_width);
    // The one rule for whole rows of an output (cone.cpp; engine.cpp's shared spectra): the
    // settings allow the pass and it pays off.
    static bool used_by_cone(const ConeSettings& settings, int level_width, int level_height, int out_width) {
        return settings.fourier_first_pass && pays_off(level_width, level_height, out_width);
    }

    // Throws RuntimeError unless the summer's level and out_width are powers of two with one
    // column class.
    FourierFirstPass(const LobeSummer& summer, int out_width, int threads);
    ~FourierFirstPass();
    FourierFirstPass(const FourierFirstPass&) = delete;
    FourierFirstPass& operator=(const FourierFirstPass&) = delete;

    // Writes whole rows `rows` of sums (made by summer.make_sums(&rows)) with cut-off c0, as
    // summer.sum_row(row, c0, sums) would (to rounding). Returns how many of them were summed in
    // pairs mirrored about the equator (one set of kernel spectra for both rows).
    int run(const std::vector<int>& rows, double c0, LobeSums& sums, const RowProgress& progress) const;

private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

}  // namespace glint::convolution
