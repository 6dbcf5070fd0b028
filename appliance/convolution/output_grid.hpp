// The grids maps are summed on and delivered at (docs/convolution.md, "Output size").
//
// A renderer reads a map by bilinear lookup at any direction, so a map's size is chosen for
// the error of those lookups, which is estimated from the computed map itself: its second
// differences bound the error of linear interpolation between texels, its fourth differences
// that of 4-point (cubic) interpolation. A map whose lookups need finer texels than it was
// summed on is resampled to them with 4-point interpolation instead of being summed again.
#pragma once

#include <vector>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/lobe_sum.hpp"
#include "appliance/convolution/methods.hpp"
#include "appliance/core/fine_tiles.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::convolution {

// Errors, relative as in docs/conventions.md (weighted RMS over texels and channels; worst
// texel against max(|value|, solid-angle mean)), predicted for lookups into a map.
struct LookupError {
    double bilinear_rms = 0;    // bilinear lookup anywhere between the map's texel centres
    double bilinear_worst = 0;  // (both with the poles' clamp below)
    double cubic_rms = 0;       // 4-point interpolation of the map to a finer grid
    double cubic_worst = 0;
    // The worst texel's two parts: the clamp at the poles (between a pole and its first row's
    // centres a lookup holds that row, docs/conventions.md, so it errs by the map's slope
    // across the pole times the distance, first order in the spacing where the rest is second
    // order) and the rest, between texels.
    double pole_worst = 0;
    double between_worst = 0;
    // The bilinear figures of the same map on a grid `factor` times finer: all but the clamp's
    // worst fall as 1 / factor^2; that one as 1 / factor. (The clamp's mean square falls as
    // 1 / factor^4 too: its error as 1 / factor over a cap 1 / factor^2 the size.)
    struct Bilinear {
        double rms = 0, worst = 0;
    };
    Bilinear finer(int factor) const;
};

// Solid-angle mean of a map over its texels and three channels (the floor of the worst-texel
// metric, docs/conventions.md).
double solid_angle_mean(const HdrImage& map);

// Per texel and channel, from the map's second differences a (in phi) and b (in theta): the
// bilinear RMS counts the mean square error over the texel's cell of bilinear interpolation
// of a quadratic with those differences, (a^2 + b^2)/120 + ab/72; the bilinear worst its
// largest value, (|a| + |b|)/8. Cubic: 3/128 (|d4_phi| + |d4_theta|), the largest error of
// 4-point interpolation, for both. Differences in theta continue across the poles (the
// row's mirror, half a turn round), in phi around the seam. The first and last rows' values
// add the poles' clamp: c = |v - v'| / 2, v' the value half a turn round (the mean of the two
// columns there for an odd width), is the error of a lookup at the pole, falling linearly to 0
// at the row's centre; c^2 / 6 in mean square over the cap, the cap's share of the row's solid
// angle (1/4 for a tall map).
// With per_texel, also each texel's estimates over its channels (TexelLookupErrors), from the
// same differences, for plan_resample_patches and plan_fine_tiles.
struct TexelErrors {
    std::vector<float> relative;   // per texel: the largest relative error over its channels
    std::vector<double> square;    // per texel: its weighted share of the squared error
    double value2 = 0;             // the map's weighted sum of squared values
};
struct TexelLookupErrors {
    TexelErrors bilinear, cubic;
};
LookupError estimate_lookup_error(const HdrImage& map, int threads, TexelLookupErrors* per_texel = nullptr);

// Below n = 1 the kernel max(0, cos)^n has a step (n = 0) or an x^n rise at the horizon, so E^n
// jumps (or turns sharply) across the great circle 90 degrees from every compact source, and
// bilinear lookups of `map` err along it in a band a texel wide, which the second differences
// above under-read about 4x. Each source's step: its energy sum L dOmega gathered in cells of the
// map's spacing h (sources closer than a texel step together), times h^n (n + 1) / 2 pi; a step
// J at a random place in a cell errs J^2 / 6 in mean square over a band of 2 pi h, a rise
// J (x/h)^n less (output_grid.cpp). bilinear_rms: that against the map's own sum dOmega E^2;
// bilinear_worst: the largest error against the map's mean. Zero for n >= 1. `input`: the
// environment map the map was convolved from.
LookupError horizon_step_error(const HdrImage& input, const HdrImage& map, double n);

// Where 4-point resampling of `map` to a finer grid would miss its budget: the texels whose
// predicted relative error (as in estimate_lookup_error) exceeds worst_budget, then those
// with the largest shares of the weighted RMS until the rest is within rms_budget. The
// finer grid's texels near them are summed exactly instead (fine_texels_near).
struct ResamplePatches {
    std::vector<char> texels;  // per texel of `map`: 1 if marked or next to a marked texel
    long long count = 0;       // texels marked (before their neighbours are added)
    double remaining_rms = 0;  // predicted RMS and worst of 4-point resampling elsewhere
    double remaining_worst = 0;
};
// `known`: the map's per-texel estimates, if the caller has them.
ResamplePatches plan_resample_patches(const HdrImage& map, double rms_budget, double worst_budget, int threads,
                                      const TexelLookupErrors* known = nullptr);

// The texels of an equirect grid `fine` whose centres lie in a cell of `coarse` (between
// its four nearest texel centres, across the seam and the poles) with a marked corner.
struct TexelSelection {
    std::vector<int> rows;                       // rows with at least one texel, ascending
    std::vector<LobeSummer::ColumnRuns> runs;    // per row of `rows`: half-open column runs
    long long texels = 0;
};
TexelSelection fine_texels_near(const std::vector<char>& marked, Size coarse, Size fine, int threads);

// Fine tiles (core/fine_tiles.hpp; docs/convolution.md, "Fine tiles"): which tiles of `base`
// (a map as summed, bright texels in) need a grid `factor` times finer for bilinear lookups.
// The base texels whose lookups would err more than worst_budget, then those with the largest
// shares of the RMS until the rest is within rms_budget (as plan_resample_patches, with the
// bilinear estimates), each with the fine cells between its neighbours' centres; the tiles of
// `tile` base texels holding those cells are kept.
class BrightLobes;
struct FineTilePlan {
    int factor = 1, tile = 0, tiles_x = 0, tiles_y = 0;
    std::vector<char> kept;    // per tile, row-major
    long long tiles = 0;       // kept
    long long marked = 0;      // base texels marked
    double remaining_rms = 0;  // bilinear lookups of the base outside the kept tiles
    double remaining_worst = 0;
};
FineTilePlan plan_fine_tiles(const HdrImage& base, int factor, int tile, double rms_budget, double worst_budget,
                             int threads, const TexelLookupErrors* known = nullptr);

// The kept tiles' fine texels: `map` resampled 4-point (as resample_cubic, at those texels
// only), negative values clamped to 0 and counted in *clamped, then `lobes` (built for the fine
// grid) applied, as resample_cubic does for the whole grid.
FineTiles make_fine_tiles(const HdrImage& map, const FineTilePlan& plan, int threads, long long* clamped,
                          const BrightLobes* lobes);

// The worst of the poles' clamp over a map's first and last rows (as in estimate_lookup_error),
// relative to max(|value|, floor_value).
double pole_clamp_worst(const HdrImage& map, double floor_value);

// The worst bilinear lookup inside the kept tiles of `base`, relative to max(|value|,
// floor_value), measured on the finer grid: the fine texels' own second differences (each
// block's interior texels, as estimate_lookup_error's worst; the lines between tiles, which no
// block can difference, are left out) and, in tiles on a pole's row,
// the clamp against the lookup half a turn round. The sum grid's estimate scaled to the finer
// grid over-predicts next to a lobe it barely resolved, and its clamp is the secant of a slope
// a finer row is much closer to.
struct TileLookupWorst {
    double between = 0;  // between the fine texels
    double pole = 0;     // in the poles' caps
    double worst() const { return std::max(between, pole); }
};
TileLookupWorst tile_lookup_worst(const HdrImage& base, const FineTiles& tiles, double floor_value);

// The worst bilinear lookup between texels of the exact map E^n (sample_lobe over `input`) on
// `grid`, measured only round the `spots` texels of `input` whose own lookups err most (relative,
// estimate_lookup_error): each spot's texel and its neighbours' span on `grid`, evaluated there
// with a texel more on every side for the second differences, as estimate_lookup_error's worst
// relative to max(|value|, the input's solid-angle mean). Rows next to a pole are left out (the
// clamp; nothing to difference across). For a lobe narrower than the input's texels the map
// follows the input's contrast, so a few spots find what the grid would miss; a spot missed only
// under-reports. The engine uses it to choose the lobe lookup before summing any grid.
double spot_lookup_worst(const HdrImage& input, double n, Size grid, int spots, int threads);

// The fine texels of the kept tiles (each texel once, a block's shared edge included), as a
// selection of the fine grid; and the same selection limited to the texels also in `other`.
TexelSelection fine_tile_texels(const FineTilePlan& plan, Size base);
TexelSelection intersect(const TexelSelection& a, const TexelSelection& b);

// Writes value rgb of fine texel (i, j) into every block that holds it; reads it from one
// (throws RuntimeError when no kept tile holds it).
void set_fine_texel(FineTiles& tiles, Size base, int i, int j, const float* rgb);
const float* fine_texel(const FineTiles& tiles, Size base, int i, int j);

// The bright texels' part of a map of shininess n at the texel centres of an out-sized grid,
// (n+1)/(2 pi) sum_b max(0, r.w_b)^n L_b dOmega_b, normalised by the continuous lobe, taken
// from the map (Subtract) or added to it with negative sums clamped to 0 (AddClamped), one
// row at a time. The terms dropped at a texel stay below 1e-3 floor_value together (1e-6 a
// bright texel up to 1000 of them; floor_value is the map's solid-angle mean where the engine
// resamples), and cells of 256 or more bright texels may be merged within 5e-4 of the bright
// terms plus 5e-4 floor_value (BrightScatter). A map summed with its bright texels split out
// (cone, sh with the bright split) is resampled without them and gets them back here.
enum class LobeOp { Subtract, AddClamped };
class BrightLobes {
public:
    BrightLobes(const std::vector<BrightTexel>& bright, double shininess, Size out, double floor_value, LobeOp op);
    // Row `row` of an out-sized map (3 floats per texel), in place; rows no bright texel
    // reaches are left as they are. Thread-safe across rows.
    void apply_row(int row, float* dst) const;
    // The same for texels of row `row` in the half-open column runs `runs` (ascending, within
    // [first_column, first_column + count)): dst holds `count` texels from first_column on.
    void apply_runs(int row, const LobeSummer::ColumnRuns& runs, int first_column, int count, float* dst) const;

private:
    BrightScatter scatter_;
    double norm_;
    LobeOp op_;
    std::vector<char> reached_;  // per output row: some bright texel's cut-off cone reaches it
};
// BrightLobes over every row of `map`.
void add_bright_lobes(const std::vector<BrightTexel>& bright, double shininess, double floor_value, LobeOp op,
                      HdrImage& map, int threads);

// `map` at the texel centres of an `out`-sized grid by separable 4-point Lagrange
// interpolation (exact for cubics), periodic in phi, across the poles in theta. Negative
// results (overshoot next to a sharp edge) are clamped to 0 and counted in *clamped. With
// `lobes` (built for `out`), each output row gets them as soon as it is written, while it is
// still in cache, instead of in a second pass over the whole map.
HdrImage resample_cubic(const HdrImage& map, Size out, int threads, long long* clamped = nullptr,
                        const BrightLobes* lobes = nullptr);

// The mirror map (n = infinity): the environment averaged over each output texel's footprint,
// weighted by solid angle (exact overlaps of the equirect cells). At the input's own size it
// is the input; coarser, the solid-angle box filter; finer, each texel takes the input texel
// it lies in.
HdrImage filter_to_footprint(const HdrImage& environment, Size out, int threads);

}  // namespace glint::convolution
