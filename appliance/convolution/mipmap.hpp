// The thesis' MIP-mapping baseline (§4.2) on an equirect map, and the solid-angle pyramid it reads.
#pragma once

#include <mutex>
#include <vector>

#include "appliance/convolution/convolution.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::convolution {

// Solid-angle-weighted 2x2 box pyramid of an equirect map: a texel of level k+1
// is sum(L * dOmega) / sum(dOmega) over its 4 children in level k, with dOmega
// exact per row of level k. A coarse texel's solid angle is exactly the sum of
// its children's, so every level holds the same total sum(L * dOmega) as the
// input (a plain 2x2 average would not: it overweights the polar rows).
// A level with an odd width or height is halved to (w + 1) / 2 x (h + 1) / 2 texels, each the
// solid-angle-weighted mean of the parts of the finer texels under it (filter_to_footprint: the
// same total), so odd inputs have a pyramid too: 999x500 -> 500x250 -> 250x125 -> 125x63 ->
// ... -> 2x1; 1024x512 -> ... -> 2x1. Halving stops at a height of 1. (Until 2026-12-06 it
// stopped at the first odd side: a 999x500 input had no coarser level, and its set took 53 s
// against 2 s from 1000x500.)
class Pyramid {
public:
    // The sizes of the levels a pyramid of a level0-sized map has, without building it.
    static std::vector<Size> level_sizes(Size level0);
    // AllLevels halves down to the last level in the constructor; OnDemand builds a level (and
    // those above it) when level() first asks for it, so that a plan reading only the input's
    // level (SH with the bright split) does not pay for the others. Level reads are thread-safe.
    enum class Build { AllLevels, OnDemand };
    // Throws InputError on an empty image; threads: for the halving.
    explicit Pyramid(HdrImage level0, int threads = 1, Build build = Build::AllLevels);
    int levels() const { return int(levels_.size()); }
    const HdrImage& level(int k) const;  // 0 = the input; throws std::out_of_range, or logic_error once released
    // Frees level k's texels (a level no plan reads: the full-resolution remainder of a large
    // input). coarser_read: coarser levels may still be asked for, so the next one is built
    // first (the others are made from it); else a coarser level not yet built cannot be read.
    void release_level(int k, bool coarser_read = true);
    bool released(int k) const;

private:
    int threads_;
    mutable std::mutex mutex_;  // guards building and the two vectors below
    // One per level, sized once by the constructor (references stay valid); level k made once
    // built_ > k.
    mutable std::vector<HdrImage> levels_;
    mutable int built_ = 0;
    std::vector<char> released_;
    void build_through(int k) const;  // with mutex_ held
};

// Thesis eq. 4.1-4.3 with the equirect height (the polar resolution) as N:
//   l_max = log2(H), l_irrad = l_max - 2, l_rad(s) = l_max - log2(min(max(s/2, 4), H)),
// i.e. the level whose height is min(max(s/2, 4), H) rows (4 rows for irradiance).
// Returned unclamped and fractional; it is negative for the irradiance level of
// maps less than 4 rows high.
double mipmap_level(int input_height, bool irradiance, double shininess);

// The levels a map reads and the weight of the coarser one: mipmap_level()
// clamped to the levels the pyramid has (textureLod clamps to the chain it has;
// its coarsest level stands in for any level beyond it; the formula takes level k
// as H / 2^k rows, which odd sizes round up by less than a row); blend 0: the fine
// level alone. The CPU's mipmap_convolve
// and the GPU engine's mipmap pass read the same.
struct MipmapLookup {
    int fine = 0, coarse = 0;
    double blend = 0;
};
MipmapLookup mipmap_lookup(const Pyramid& pyramid, bool irradiance, double shininess);

// Reads the pyramid at mipmap_level(), clamped to the levels it has, at the
// direction of each output texel centre with sample_bilinear(); a fractional
// level blends the lookups of the two neighbouring levels linearly, as
// textureLod with trilinear filtering does. Throws InputError for a negative or
// NaN shininess (irradiance ignores it) or an empty output size.
HdrImage mipmap_convolve(const Pyramid& pyramid, bool irradiance, double shininess, int out_width,
                         int out_height);

}  // namespace glint::convolution
