// Error and cost models behind `auto`, and the per-method plans.
#include "appliance/convolution/planner.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <iomanip>
#include <sstream>
#include <string>

#include "appliance/convolution/lobe_sum.hpp"
#include "appliance/convolution/methods.hpp"
#include "appliance/convolution/sh.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"

namespace glint::convolution {
namespace {

double texel_spacing(Size s) { return kPi / s.height; }

long long texels(Size s) { return (long long)s.width * s.height; }

// Multiply-adds of a lobe sum: output texels x input texels inside the cone.
double lobe_cost(Size out, Size level, double cut_cos) {
    const double cap = kTwoPi * (1.0 - std::max(0.0, cut_cos));  // solid angle of the cone
    const double per_texel = 4.0 * kPi / double(texels(level));
    return double(texels(out)) * std::max(1.0, cap / per_texel);
}

// What the planner reads of the environment map.
struct EnvironmentShape {
    Size input;
    std::vector<Size> cone_levels;  // pyramid of the remainder after the bright split
};

}  // namespace

double lobe_width(double n) { return n <= 1.0 ? 1.0 : 1.0 / std::sqrt(n); }

int bright_texel_cap(const PlannerModel& model, int width, int height) {
    const double per_reference = double(width) * double(height) / (1024.0 * 512.0);
    return int(std::min(2.0e9, std::ceil(double(model.max_bright_texels) * std::max(1.0, per_reference))));
}

Size sum_grid_size(double n, Size input, const PlannerModel& model) {
    const int cap = input.height;
    if (std::isinf(n)) return {2 * cap, cap};
    const double spacing = model.sum_grid_spacing * lobe_width(n);
    const int needed = std::max(model.min_output_height, int(std::ceil(kPi / spacing)));
    // A lobe finer than the ladder's spacing but within one texel of the input's grid is
    // summed on the input's grid: its lookups need finer texels, which the output delivery
    // makes by resampling with the texels near sharp content summed exactly on the finer grid
    // (deliver_output), or, where that is most of them, by summing again on twice the grid.
    // (Summing all of these on twice the input's height was cheaper before the exact patches;
    // with them the input's grid costs less: the n = 5120 and 20480 maps of courtyard, studio
    // and sunset from 1024x512 took 0.77, 1.13 and 0.43 s of CPU against 0.83, 1.65 and 0.54 s,
    // 2026-12-02, perf stat task-clock.) A lobe narrower than the input's texels (but not than
    // half of them, which stays on the input's grid) is summed on twice the input's height:
    // 4-point resampling is not predicted where the grid does not resolve the lobe, and the
    // coarse grid's lookup estimate would under-predict.
    // An odd input width: a grid 2 h wide shares no factor with it, so every output column is a
    // phase class of its own and the sums lose their unit-stride runs (lobe_sum.hpp): 6.6 s
    // for n = 5120 from 1023x511 against ~0.2 s from 1024x512 (2026-12-06). Such a map is summed
    // on twice the input's grid (2 W x 2 H, two classes), whose texels are a hair off square.
    // Only for a 2:1 input (W = 2 H +- 1; another aspect keeps 2 h x h, which shares a factor
    // with W or not as it happens) and within kMaxOutputHeight rows.
    const bool odd_twice =
        input.width % 2 != 0 && std::abs(input.width - 2 * input.height) <= 1 && 2 * cap <= kMaxOutputHeight;
    const Size twice = odd_twice ? Size{2 * input.width, 2 * cap} : Size{4 * cap, 2 * cap};
    if (needed > cap && needed >= model.min_output_height * 2 && kPi / cap > lobe_width(n) &&
        !lobe_narrower_than_input(n, input))
        return twice;
    if (needed >= cap) return odd_twice ? twice : Size{2 * cap, cap};
    // The ladder: the input's height halved k times, so the level's columns fall in few
    // phase classes of the output's (one where the widths divide), and the sums stay
    // unit-stride runs (lobe_sum.hpp). A 3/4 step too measured slower than the full step
    // above it: three classes of a third of the columns each.
    int best = cap;
    for (int h = cap; h >= 2; h /= 2) {
        if (h >= needed && h < best) best = h;
        if (h % 2) break;
    }
    if (best > needed * 2) {
        // An odd height ends the halving ladder far above what the lobe needs (1500 -> 750 ->
        // 375 against 106 rows): the smallest height h >= needed that divides the input's height
        // with a width 2 h that divides the input's width, so the level's columns still fall in
        // few phase classes (250x125 from 3000x1500: one against level 1's 1500 columns, two
        // against level 3's 375). A grid of `needed` rows shares no factor with the levels and
        // makes every output column a class of its own: 212x106's n = 640 from 3000x1500 took
        // 3.3 s, its exact texels (summed per class) most of it. Within twice the rows needed,
        // else `needed` as it is.
        int aligned = 0;
        for (int d = 2; cap / d >= needed; ++d)
            if (cap % d == 0 && (static_cast<long long>(input.width) * d) % (2LL * cap) == 0) aligned = cap / d;
        best = aligned > 0 && aligned <= needed * 2 ? aligned : needed + (needed & 1);
    }
    if (best == cap && odd_twice) return twice;  // the input's own height, an odd width
    return {2 * best, best};
}

bool lobe_narrower_than_input(double n, Size input) {
    const double half_texel = 0.5 * kPi / input.height;
    return lobe_width(n) < half_texel;
}

// The level model's growth with the texel spacing h (planner.hpp): h^2 max(n, n_min) for
// n >= 1. Below n = 1 the kernel max(0, cos)^n is a step (n = 0) or has an infinite slope at
// the horizon, and a coarse texel across the horizon errs to first order: n_min h^(1 + n), the
// same at n = 1. Measured on a 100x50 noise map read from its 50x25 level (h = 0.126, a sweep of
// generated maps, 2026-12-06): n = 0 1.55 % RMS and 9.5 % worst, n = 0.25 0.75 %, n = 0.5
// 0.51 %, where h^2 max(n, 5) had predicted 0.24 %.
double level_growth(double h, double n, const PlannerModel& model) {
    if (n >= 1.0) return h * h * std::max(n, model.level_min_shininess);
    return model.level_min_shininess * std::pow(h, 1.0 + std::max(n, 0.0));
}

double merged_arc_budget(double n, double tolerance, const PlannerModel& model) {
    const double worst = model.level_worst_share * tolerance / model.level_worst_coefficient;
    const double rms = model.level_share * tolerance / model.level_rms_coefficient;
    // The arc h whose level_growth is the smaller budget.
    const double budget = std::min(worst, rms);
    if (n >= 1.0) return std::sqrt(budget / std::max(n, model.level_min_shininess));
    return std::pow(budget / model.level_min_shininess, 1.0 / (1.0 + std::max(n, 0.0)));
}

namespace {

// ConeSettings that realise a cone plan for shininess n.
ConeSettings cone_settings(double tolerance, double n, const PlannerModel& model) {
    ConeSettings s;
    s.max_texel_arc = merged_arc_budget(n, tolerance, model);
    // The rough rows' first-order error, 0.61 sqrt(n) x arc x roughness, doubled for the
    // lobe's peak against its mean over the merged groups, within the level's worst share.
    s.max_arc_roughness = model.level_worst_share * tolerance / (1.2 * std::sqrt(std::max(n, model.level_min_shininess)));
    s.cutoff_energy = model.first_cut_energy * tolerance;
    s.texel_tolerance = model.texel_cut_share * tolerance;
    s.bright_tolerance = model.bright_drop_share * tolerance;
    return s;
}

// SH order for shininess n whose kernel tail is negligible against tolerance.
int sh_order_for(double n, double tolerance) {
    const std::vector<double> k = phong_sh_kernel(n, kMaxShOrder);
    // Smallest order after which every kernel coefficient stays below tau / 100.
    int order = kMaxShOrder;
    for (int l = kMaxShOrder - 1; l >= 0; --l) {
        if (std::abs(k[std::size_t(l)]) >= tolerance * 1e-2) break;
        order = l;
    }
    return std::max(order, 1);
}

// The plan for one map under the given options.
MapPlan plan_map(const MapRequest& request, const Options& options, const EnvironmentShape& env,
                 const PlannerModel& model) {
    const double n = request.shininess;
    const double tau = options.tolerance;
    MapPlan plan;
    // A cone plan runs with these; so does the cone that computes the failing
    // rows of a plan auto moves to SH with the bright split (any of its plans).
    plan.cone = cone_settings(tau, n, model);
    const ConeSettings& cone = plan.cone;
    const double cut_cos = cone_cut_cos(cone.cutoff_energy, n);
    const std::optional<Size> fixed = request.size ? request.size : options.size;
    const Size grid = sum_grid_size(n, env.input, model);
    plan.size_fixed = bool(fixed);
    plan.output_size = fixed ? *fixed : grid;
    plan.sum_size = plan.output_size;
    plan.size_reason = fixed ? "fixed by the request" : "the lobe's sum grid";
    // The error of bilinear lookups between the output's texels is not planned: the engine
    // measures it on the computed map (output_grid.hpp) and adds it to predicted_error.
    if (request.mirror) {
        plan.method = Method::Mirror;
        plan.input_level = 0;
        plan.input_size = env.input;
        plan.cutoff_cos = -1;
        plan.predicted_error = 0;  // the definition of the mirror map
        plan.predicted_cost = double(texels(plan.output_size)) + double(texels(env.input));
        plan.size_reason = fixed ? "fixed by the request" : "the input's grid (mirror)";
        return plan;
    }
    // Also a lobe under one texel whose bilinear plan would sum on twice the input's height beyond
    // kMaxOutputHeight (4096x2048 inputs and larger: 8192x4096 sums, 400 MB, that still missed the
    // worst-texel share at 50 %, 2026-12-05): the lobe lookup at once.
    const bool beyond_grids = !request.irradiance && lobe_width(n) < kPi / env.input.height &&
                              2 * env.input.height > kMaxOutputHeight;
    if (!fixed && (lobe_narrower_than_input(n, env.input) || beyond_grids)) {
        // The lobe lookup: the map is the input's texels (the mirror's map at the input's grid,
        // its computation), and the reader sums the lobe over the few texels near each direction
        // (sample_lobe). It skips only terms below exp(-kLobeLookupSpan) of the largest.
        plan.method = Method::Mirror;
        plan.lookup = MapLookup::Lobe;
        plan.input_level = 0;
        plan.input_size = env.input;
        plan.output_size = plan.sum_size = env.input;
        plan.cutoff_cos = -1;
        plan.lookup_error = 0;
        plan.predicted_error = 0;
        plan.predicted_cost = double(texels(env.input));
        plan.size_reason = lobe_narrower_than_input(n, env.input)
                               ? "the input's grid, read through the lobe: it is narrower than half the input's texel "
                                 "spacing, so between texel centres the exact sum is a step that bilinear lookups of "
                                 "no grid follow; the map holds the input's texels and a reader applies the lobe to "
                                 "them (lookup \"lobe\")"
                               : "the input's grid, read through the lobe: it is narrower than the input's texel "
                                 "spacing, and a grid fine enough for bilinear lookups would exceed " +
                                     std::to_string(kMaxOutputHeight) +
                                     " rows; the map holds the input's texels and a reader applies the lobe to them "
                                     "(lookup \"lobe\")";
        return plan;
    }
    // A lobe far narrower than the input's texels at a fixed size (auto): E at each output
    // texel's centre from the input texels near it (sample_lobe, every term within
    // exp(-kLobeLookupSpan) of the largest), the conventions' sum itself. The cone's cutoff is
    // an angle: with the lobe under a fifth of a texel it held no texel centre near some output
    // centres, and a single bright texel on black came out black (100 % off, predicted 0.1 %;
    // a sweep of generated maps, 2026-12-06); coarse inputs read at finer sizes (8x4 at 65x33,
    // n = 160) erred 29 % worst.
    // It applies where the cone's cut-off angle is under one input texel spacing (the misses
    // began at 0.9: n = 4e4 and 3e4 on 256x128, 2.6 % and 0.79 % worst): past that the cone holds
    // the texels whose weights count and costs far less (n = 1e6 from 4096x2048 at 2048x1024:
    // 0.5 s against 32 s; n = 2e5 from 1024x512 at 1024x512: 0.19 s against 2.6 s, within 7e-7;
    // the lobe's sums reach e^-36 of the largest weight, whole rows at the poles).
    if (fixed && !request.irradiance && options.method == Method::Auto &&
        std::acos(std::clamp(cut_cos, -1.0, 1.0)) < kPi / env.input.height) {
        plan.method = Method::Lobe;
        plan.input_level = 0;
        plan.input_size = env.input;
        plan.cutoff_cos = -1;
        plan.predicted_error = 0;
        // Texels visited per output texel: a disc of radius sqrt(2 span / n) plus a texel; the
        // output rows within that reach of a pole read whole input rows.
        const double reach = std::sqrt(2.0 * kLobeLookupSpan / n) / (kPi / env.input.height) + 1.0;
        const double polar_rows =
            std::min(double(plan.output_size.height), 2.0 * std::ceil(reach * plan.output_size.height / env.input.height));
        plan.predicted_cost = double(texels(plan.output_size)) * kPi * reach * reach +
                              polar_rows * plan.output_size.width * reach * env.input.width;
        plan.size_reason = "fixed by the request; the lobe is so narrow against the input's texels that a cone's "
                           "cut-off would hold few of them, so each texel is the lobe's sum over the input texels "
                           "near its centre (sample_lobe)";
        return plan;
    }
    // Only the cone sums at a coarser grid than a fixed output and resamples (exact and
    // mipmap are what they are at the size asked; SH reconstructs at any size).
    const bool may_resample = fixed && grid.height < fixed->height &&
                              (options.method == Method::Auto || options.method == Method::Cone);
    const Size out = plan.output_size;
    const Size cone_grid = may_resample ? grid : out;  // where a cone plan sums

    const auto plan_exact = [&] {
        plan.method = Method::Exact;
        plan.sum_size = plan.output_size;
        if (fixed) plan.size_reason = "fixed by the request";
        plan.predicted_error = 0;
        plan.input_level = 0;
        plan.input_size = env.input;
        plan.cutoff_cos = 0.0;
        plan.predicted_cost = lobe_cost(out, env.input, 0.0);
    };
    const auto plan_cone = [&] {
        // Coarsest level whose predicted error fits the level share of tau.
        int level = 0;
        double level_error = 0;
        for (int k = 1; k < int(env.cone_levels.size()); ++k) {
            const double h = texel_spacing(env.cone_levels[std::size_t(k)]);
            const double h2n = level_growth(h, n, model);
            if (model.level_worst_coefficient * h2n > model.level_worst_share * tau ||
                model.level_rms_coefficient * h2n > model.level_share * tau)
                break;
            level = k;
            level_error = model.level_rms_coefficient * h2n;
        }
        // Rows near the poles that read merged columns: a texel as wide as the
        // widest merged one, by the same model.
        const Size ls = env.cone_levels[std::size_t(level)];
        const double widest = widest_merged_arc(ls.width, ls.height, cone_grid.width, cone.max_texel_arc);
        const double h_level = level > 0 ? texel_spacing(ls) : 0.0;
        if (widest > h_level)
            level_error = model.level_rms_coefficient * level_growth(widest, n, model);
        plan.method = Method::Cone;
        plan.input_level = level;
        plan.input_size = env.cone_levels[std::size_t(level)];
        plan.cutoff_cos = cut_cos;
        plan.predicted_error = level_error + cone.cutoff_energy;
        if (may_resample) {
            plan.sum_size = grid;
            plan.size_reason = "fixed by the request; summed on the lobe's grid and resampled";
        }
        plan.predicted_cost = lobe_cost(plan.sum_size, plan.input_size, cut_cos);
    };

    switch (options.method) {
        case Method::Exact:
        case Method::Mirror:  // not options: mirror and lobe maps are planned above
        case Method::Lobe:
            plan_exact();
            break;
        case Method::Cone:
            plan_cone();
            break;
        case Method::Mipmap: {
            plan.method = Method::Mipmap;
            plan.input_size = env.input;
            plan.predicted_error = std::numeric_limits<double>::quiet_NaN();  // no error model
            plan.predicted_cost = double(texels(out)) * 8.0;
            break;
        }
        case Method::Sh: {
            plan.method = Method::Sh;
            plan.input_size = env.input;
            plan.sh_order = options.sh_order > 0 ? options.sh_order : sh_order_for(n, tau);
            const std::vector<double> k = phong_sh_kernel(n, plan.sh_order + 1);
            plan.predicted_error += std::abs(k[std::size_t(plan.sh_order)]);  // first dropped band
            const double order = plan.sh_order;
            plan.predicted_cost = double(texels(env.input)) * order * 3.0 +
                                  double(texels(out)) * order * 2.0 + order * order * out.height;
            break;
        }
        case Method::Auto: {
            plan_cone();
            const MapPlan cone_plan = plan;
            plan_exact();
            // The exact sum wins only on maps too small for a pyramid to help.
            if (cone_plan.predicted_cost < plan.predicted_cost) plan = cone_plan;
            break;
        }
    }
    return plan;
}

// Predicted seconds to project a level of `size` onto `order` bands.
double sh_projection_seconds(Size size, int order, const PlannerModel& model) {
    // Per row: an FFT (or direct sums) per channel, then order^2/2 Legendre
    // values times 2 (cos, sin) times 3 channels.
    const double rows = size.height;
    const double fourier = double(size.width) * std::log2(std::max(2, size.width)) * 3.0 * 4.0;
    return rows * (fourier + double(order) * order * 3.0) * model.sh_step_seconds;
}

// The SH-with-bright-split alternative for one map (auto only).
struct ShSplitPlan {
    bool usable = false;
    int order = 0;
    int level = 0;                 // pyramid level of the remainder that is projected
    double predicted_error = 0;
    double reconstruct_seconds = 0;
};
ShSplitPlan plan_sh_split(double n, double tau, Size out, const EnvironmentShape& env,
                          const PlannerModel& model) {
    ShSplitPlan plan;
    if (n <= 1.0) return plan;  // the clamped cosine's kernel decays too slowly for the bound
    int order = 0;
    const std::vector<double> tails = sh_truncation_tails(n, model.max_split_sh_order);
    for (int l = 4; l <= model.max_split_sh_order; l += 4)
        if (tails[std::size_t(l)] <= model.sh_tail_share * tau) {
            order = l;
            break;
        }
    if (order == 0) return plan;
    int level = -1;
    double level_error = 0;
    for (int k = 0; k < int(env.cone_levels.size()); ++k) {
        const Size s = env.cone_levels[std::size_t(k)];
        if (s.height < order || s.width < 2 * order) break;  // the grid must resolve the bands
        const double h = texel_spacing(s);
        const double h2n = level_growth(h, n, model);
        if (k > 0 && (model.level_worst_coefficient * h2n > model.level_worst_share * tau ||
                      model.level_rms_coefficient * h2n > model.level_share * tau))
            break;
        level = k;
        level_error = k > 0 ? model.level_rms_coefficient * h2n : 0.0;
    }
    if (level < 0) return plan;
    plan.usable = true;
    plan.order = order;
    plan.level = level;
    plan.predicted_error = level_error + model.sh_tail_share * tau;
    plan.reconstruct_seconds =
        (double(out.height) * (double(order) * order * 3.0 +
                               double(out.width) * std::log2(std::max(2, out.width)) * 3.0 * 4.0)) *
        model.sh_step_seconds;
    return plan;
}

// Auto: moves maps from the cone to SH with the bright split where that is
// predicted to be faster, counting the one shared projection. Greedy by saving.
void choose_sh_split(const std::vector<MapRequest>& maps, std::vector<MapPlan>& plans, double tau,
                     const EnvironmentShape& shape, const PlannerModel& model) {
    struct Candidate {
        std::size_t index;
        ShSplitPlan sh;
        double cone_s;
    };
    std::vector<Candidate> candidates;
    for (std::size_t k = 0; k < plans.size(); ++k) {
        const MapPlan& p = plans[k];
        if (p.method == Method::Mirror || p.method == Method::Lobe) continue;
        const ShSplitPlan sh = plan_sh_split(maps[k].shininess, tau, p.output_size, shape, model);
        const double cone_s = predicted_seconds(p, model);
        if (sh.usable && sh.reconstruct_seconds < cone_s) candidates.push_back({k, sh, cone_s});
    }
    std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
        return a.cone_s - a.sh.reconstruct_seconds > b.cone_s - b.sh.reconstruct_seconds;
    });
    int level = std::numeric_limits<int>::max(), order = 0;
    double projection = 0;
    std::vector<const Candidate*> chosen;
    for (const Candidate& c : candidates) {
        const int new_level = std::min(level, c.sh.level);
        const int new_order = std::max(order, c.sh.order);
        const double new_projection =
            sh_projection_seconds(shape.cone_levels[std::size_t(new_level)], new_order, model);
        if (new_projection - projection + c.sh.reconstruct_seconds < c.cone_s) {
            level = new_level;
            order = new_order;
            projection = new_projection;
            chosen.push_back(&c);
        }
    }
    for (const Candidate* c : chosen) {
        MapPlan& p = plans[c->index];
        p.method = Method::Sh;
        p.bright_split = true;
        if (p.size_fixed) p.size_reason = "fixed by the request";
        p.sum_size = p.output_size;  // SH reconstructs at any size
        p.sh_order = c->sh.order;
        p.projection_order = order;
        p.fallback_level = p.input_level;  // the cone's, for rows whose SH bound fails
        p.input_level = level;  // the shared projection's level (at least as fine as this map's)
        p.input_size = shape.cone_levels[std::size_t(level)];
        p.cutoff_cos = -1;
        p.predicted_error = c->sh.predicted_error;
        p.predicted_cost = c->sh.reconstruct_seconds / model.sh_step_seconds;
    }
}

// As many digits as tell v apart ("1e+07" and "1.0000001e+07", not both "1e+07").
std::string number(double v) {
    std::ostringstream s;
    s << std::setprecision(12) << v;
    return s.str();
}

}  // namespace

void validate_plan_inputs(Size input, const std::vector<MapRequest>& maps, const Options& options) {
    if (input.width <= 0 || input.height <= 0) throw InputError("environment map is empty (0 texels)");
    if (input.width < 2 || input.height < 2)
        throw InputError("environment map " + to_string(input) + " is too small (needs at least 2x2)");
    if (maps.empty()) throw InputError("no maps requested (give --irradiance, --shininess and/or --mirror)");
    for (const MapRequest& m : maps) {
        if (!m.mirror && (!std::isfinite(m.shininess) || m.shininess < 0))
            throw InputError("shininess of " + m.label + " must be a finite number >= 0, not " +
                             number(m.shininess));
        if (!m.mirror && m.shininess > kMaxShininess)
            throw InputError("shininess of " + m.label + " must be at most " + number(kMaxShininess) + ", not " +
                             number(m.shininess) + " (a sharper lobe is a mirror: ask for the mirror map)");
        if (m.size && (m.size->width < 2 || m.size->height < 2))
            throw InputError("output size of " + m.label + " must be at least 2x2, not " + to_string(*m.size));
    }
    if (!(options.tolerance > 0) || !(options.tolerance < 1))
        throw InputError("--tolerance must be in (0, 1), e.g. 0.01 for 1 %, not " + number(options.tolerance));
    if (options.size && (options.size->width < 2 || options.size->height < 2))
        throw InputError("--size must be at least 2x2, not " + to_string(*options.size));
    if (options.sh_order < 0 || options.sh_order > 1024)
        throw InputError("--sh-order must be in [1, 1024] (0: the planner's choice), not " +
                         std::to_string(options.sh_order));
}

double predicted_seconds(const MapPlan& plan, const PlannerModel& model) {
    return plan.predicted_cost * (plan.method == Method::Sh ? model.sh_step_seconds : model.cone_term_seconds);
}

std::vector<MapPlan> plan_maps(Size input, const std::vector<MapRequest>& maps, const Options& options,
                               const std::function<std::vector<Size>()>& cone_levels,
                               const PlannerModel& model) {
    validate_plan_inputs(input, maps, options);
    EnvironmentShape shape{input, {input}};
    if (options.method == Method::Auto || options.method == Method::Cone) shape.cone_levels = cone_levels();
    std::vector<MapPlan> plans;
    for (const MapRequest& m : maps) plans.push_back(plan_map(m, options, shape, model));
    if (options.method == Method::Auto) choose_sh_split(maps, plans, options.tolerance, shape, model);
    return plans;
}

}  // namespace glint::convolution
