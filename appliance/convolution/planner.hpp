// The planner: for each wanted map, the method, input level, output size and
// cut-off whose predicted error is within the tolerance at the least predicted
// cost: only the maps the scene uses, each no finer than its lobe needs (docs/convolution.md).
#pragma once

#include <functional>
#include <vector>

#include "appliance/convolution/convolution.hpp"

namespace glint::convolution {

// Tunables of the error model, named so that tests and docs can refer to them.
struct PlannerModel {
    // Reading a level whose texels are h rad apart instead of the input is a
    // midpoint rule over each coarse texel: for a lobe exp(-n a^2 / 2) its
    // relative error scales as h^2 n (second derivative over value; 1/24 for a
    // smooth map). Edges inside a coarse texel make it larger, and for n <= 5
    // the kink of the clamped cosine at the horizon dominates, so n is taken
    // as at least level_min_shininess; below n = 1 the error is first order in h
    // (level_growth). Measured on the test maps (docs/convolution.md): worst texel
    // ~0.3 h^2 n, weighted RMS ~0.03 h^2 n.
    double level_worst_coefficient = 0.3;
    double level_rms_coefficient = 0.03;
    double level_min_shininess = 5.0;
    // The level's worst texel may use this multiple of tau (the benchmark's
    // target is a worst texel within 5 % when tau = 1 %; the cut-off bound takes
    // another texel_cut_share of tau).
    double level_worst_share = 3.5;
    // Output grids (output_grid.hpp). A map is summed on the coarsest grid of the ladder
    // (sum_grid_height) whose spacing is within sum_grid_spacing lobe widths, at least
    // min_output_height rows and never finer than the input. Its bilinear lookups may then
    // err output_share * tau (weighted RMS) and output_worst_share * tau (worst texel), as
    // estimated on the map; where they would err more, the map is resampled by 4-point
    // interpolation to a grid up to max_refinement times finer (and kMaxOutputHeight rows),
    // if that interpolation errs within resample_share * tau (RMS) and resample_worst_share *
    // tau (worst), else summed again on that grid. Fine tiles (a finer grid only where lookups
    // need it) go twice as fine while the worst lookup measured in them misses its share, up to
    // max_tile_refinement: a few tiles 8x finer cost less than the whole map 4x finer, and the
    // edges of sharp lobes round lamps may need them (a panel light's n = 5120 from 512x256
    // erred 6.1 % worst off-grid at 4x).
    double sum_grid_spacing = 0.75;
    int min_output_height = 32;
    double output_worst_share = 4.0;
    int max_refinement = 4;
    int max_tile_refinement = 8;
    double resample_share = 0.25;
    double resample_worst_share = 2.0;
    // Shares of the tolerance.
    double level_share = 0.5;
    double output_share = 0.5;
    double texel_cut_share = 0.5;   // per-texel bound on the cut-off error
    double first_cut_energy = 0.1;  // first cone drops this fraction of tau of the lobe
    double bright_contrast = 64.0;  // texels brighter than this x mean are summed exactly
    int max_bright_texels = 1024;   // per 1024x512 input texels (bright_texel_cap)
    // The bright texels' terms dropped at an output texel, together, at most this share of tau
    // times the smallest output (BrightScatter; a thousandth of it per texel below 1000 texels).
    // Until 2026-12-05 each term could drop 1e-3 tau, which added up to about tau for studio's
    // 1024 lamp texels, and to 16-64 tau once the cap grew with the input. Where the scatter's
    // weights are the lobe's own (SH, resampling), cells of bright texels merged into one term
    // may add half this share of the bright terms and of the smallest output (merge_bright_cells).
    double bright_drop_share = 0.25;
    // SH with the bright split: the order is the smallest whose truncation tail
    // (sh_methods.cpp) is below sh_tail_share * tau, so the per-texel check passes
    // wherever E >= mean_R * sh_tail_share / texel_cut_share; at most this order.
    double sh_tail_share = 1e-4;
    int max_split_sh_order = 384;
    // Seconds per unit of predicted cost on the reference machine (2 threads),
    // measured with the benchmark: a cone term (3 multiply-adds, including the
    // refinement passes) and one step of the SH Legendre sums.
    double cone_term_seconds = 2.0e-9;
    double sh_step_seconds = 0.07e-9;
};

// Lobe width in radians of cos^n (about 1/sqrt(n)); the hemisphere for n <= 1.
double lobe_width(double shininess);

// The most bright texels split off an input of width x height: max_bright_texels per 1024x512
// texels, so that the same solid angle of bright sources is taken out at every input size. With
// one cap for all sizes, a 2048x1024 photograph of a lamp (four times the texels) left most of it
// in the remainder, whose coarser pyramid levels move it by a level texel, an error the level
// model (smooth content) does not see: studio's n = 640 map erred 10 % at a texel against its
// input's own exact sums, 3 % with the scaled cap.
int bright_texel_cap(const PlannerModel& model, int width, int height);

// The grid a map of shininess n is summed on when no size is fixed: on the ladder of
// sizes that share columns with the input (its height over powers of two),
// the coarsest whose texel spacing is within sum_grid_spacing lobe widths, at least
// min_output_height rows and at most the input's height, or twice the input's height for a
// lobe the input's grid does not resolve (unless it is narrower than half the input's texels);
// width twice the height. A mirror (n = infinity) is the input's size. Where bilinear lookups
// need finer texels than the sum grid, the engine delivers a finer map (PlannerModel).
inline constexpr int kMaxOutputHeight = 2048;
// The finest grid fine tiles may reach where a map would otherwise miss the tolerance: a few
// tiles of it take far less memory than a whole grid (3000x1500's n = 20480 sums on 1500x750,
// whose tiles 2x finer, all that 2048 rows allowed, left it at 1.32 % predicted: refused;
// 5376x2688's n = 1e5 needs 5376 rows).
inline constexpr int kMaxTiledHeight = 8192;
// The sharpest finite lobe planned (tested); a sharper one is asked for as the mirror map.
inline constexpr double kMaxShininess = 1e7;
Size sum_grid_size(double shininess, Size input, const PlannerModel& model);

// Lobe narrower than half the input's texel spacing (width 1/sqrt(n) < pi / (2 H)): between
// the input's texel centres the exact sum is then a step at every texel edge that no output
// grid resolves for bilinear lookups. Without a fixed size such a map is the input's texels,
// read through the lobe (MapPlan::lookup, sample_lobe; docs/convolution.md, "The lobe lookup").
bool lobe_narrower_than_input(double shininess, Size input);

// The one check of the plan inputs (input size, maps, tolerance, sizes, SH order): throws
// InputError saying what is accepted and what was given. plan_maps() calls it first; a command
// may call it earlier, to reject bad input before it opens a GL context or writes anything.
void validate_plan_inputs(Size input, const std::vector<MapRequest>& maps, const Options& options);

// The plans of one convolve() call, one per map, in order: for each map the
// method, level, output size, cut-off and cone settings under `options`; with
// auto, the maps then moved to SH with the bright split (one projection shared
// by them) where that is predicted to be faster. Validates the plan inputs
// first (input size, maps, tolerance, sizes, SH order) and throws InputError
// saying what is accepted. cone_levels: the sizes of the remainder's pyramid
// (after the bright split), called only when a plan may read it (auto, cone).
std::vector<MapPlan> plan_maps(Size input, const std::vector<MapRequest>& maps, const Options& options,
                               const std::function<std::vector<Size>()>& cone_levels,
                               const PlannerModel& model);

// Predicted seconds of a plan on the reference machine (the cost model's
// units); the CPU engine schedules the longest first.
double predicted_seconds(const MapPlan& plan, const PlannerModel& model);

// The widest texel (radians of arc) that the level error model accepts for
// a lobe of shininess n: the arc up to which rows near the poles may read
// merged columns.
double merged_arc_budget(double shininess, double tolerance, const PlannerModel& model);
// How a level's error grows with its texel spacing h for shininess n: h^2 max(n,
// level_min_shininess), and level_min_shininess h^(1 + n) below n = 1 (the horizon's step or
// infinite slope; planner.cpp). Times level_rms_coefficient or level_worst_coefficient.
double level_growth(double h, double shininess, const PlannerModel& model);

}  // namespace glint::convolution
