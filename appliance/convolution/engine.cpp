// convolve(): has the planner validate the request and plan every map, builds
// what the plans share (prepared levels, the bright split and its pyramid, SH
// coefficients) once, runs each map's plan as it stands and times it.
#include <atomic>
#include <algorithm>
#include <chrono>
#include <functional>
#include <cmath>
#include <map>
#include <mutex>
#include <limits>
#include <optional>
#include <set>
#include <tuple>
#include <memory>
#include <sstream>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/fourier_pass.hpp"
#include "appliance/convolution/methods.hpp"
#include "appliance/convolution/mipmap.hpp"
#include "appliance/convolution/output_grid.hpp"
#include "appliance/convolution/planner.hpp"
#include "appliance/convolution/sh.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::convolution {

std::string to_string(Method m) {
    switch (m) {
        case Method::Auto: return "auto";
        case Method::Exact: return "exact";
        case Method::Cone: return "cone";
        case Method::Sh: return "sh";
        case Method::Mipmap: return "mipmap";
        case Method::Mirror: return "mirror";
        case Method::Lobe: return "lobe";
    }
    return "unknown";
}

std::string to_string(Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); }

std::optional<Method> parse_method(const std::string& name) {
    for (Method m : {Method::Auto, Method::Exact, Method::Cone, Method::Sh, Method::Mipmap})
        if (to_string(m) == name) return m;
    return std::nullopt;
}

MapRequest MapRequest::make_irradiance() { return {true, false, 1.0, "irradiance", std::nullopt}; }

MapRequest MapRequest::make_phong(double n, const std::string& as_given) {
    return {false, false, n, "phong_" + as_given, std::nullopt};
}

MapRequest MapRequest::make_mirror() {
    return {false, true, std::numeric_limits<double>::infinity(), "mirror", std::nullopt};
}

namespace {

// Everything derived from the environment map that several maps may share.
class SharedInputs {
public:
    SharedInputs(const HdrImage& env, const PlannerModel& model, int threads)
        : env_(env), model_(model), threads_(threads) {}

    const HdrImage& full_image() const {
        if (consumed_) throw RuntimeError("internal: the input map was handed to the bright split and is read again");
        return env_;
    }
    // The caller handed the map over and no plan reads it whole: the bright split may zero its
    // bright texels in place instead of copying it (a 8192x4096 map is 400 MB).
    void allow_consuming(HdrImage* owned) { consumable_ = owned; }
    // No plan reads the remainder's full-resolution level: freed once level 1 is made from it.
    void release_level0_after_pyramid() { release_level0_ = true; }
    const PreparedLevel& full_level() {
        if (!full_) full_ = std::make_unique<PreparedLevel>(full_image(), threads_);
        return *full_;
    }
    const BrightSplit& bright() {
        if (!bright_) {
            // Before the input may be moved from (env_ can be the image consumable_ points at).
            const int cap = bright_texel_cap(model_, env_.width(), env_.height());
            if (consumable_) {
                consumed_ = true;
                bright_ = std::make_unique<BrightSplit>(
                    split_bright(std::move(*consumable_), model_.bright_contrast, cap, threads_));
            } else {
                bright_ = std::make_unique<BrightSplit>(
                    split_bright(env_, model_.bright_contrast, cap, threads_));
            }
        }
        return *bright_;
    }
    const Pyramid& cone_pyramid() {
        // The pyramid takes the remainder over (its level 0 is the remainder).
        if (!cone_pyramid_) {
            bright();
            // Levels built as plans read them (an SH map reads only the input's level); releasing
            // level 0 builds level 1 first, the rest come from it.
            cone_pyramid_ = std::make_unique<Pyramid>(std::move(bright_->remainder), threads_, Pyramid::Build::OnDemand);
            if (release_level0_) cone_pyramid_->release_level(0);
        }
        return *cone_pyramid_;
    }
    // Level k of the remainder laid out for the cone, built on first use (an SH map's fallback
    // level only when its bound fails somewhere). Maps running in parallel may ask for a level at
    // once: the first builds it under the level's own lock, and maps reading others do not wait.
    const PreparedLevel& cone_level(int k) {
        LevelSlot& slot = level_slot(k);
        const std::lock_guard lock(slot.build);
        if (!slot.level) slot.level = std::make_unique<PreparedLevel>(cone_pyramid().level(k), threads_);
        return *slot.level;
    }
    // Level k's layouts built on demand (PreparedLevel::release_layouts), if the level is built.
    void release_cone_layouts(int k) {
        LevelSlot& slot = level_slot(k);
        const std::lock_guard lock(slot.build);
        if (slot.level) slot.level->release_layouts();
    }
    // No map still to run reads level k of the remainder: its layouts (planes, phase copies,
    // merged columns) and its pyramid level are freed (a 4096x2048 level with its layouts
    // for two output widths is ~500 MB).
    // coarser_read: a map still to run reads a coarser level (built from this one if not yet).
    void release_cone_level(int k, bool coarser_read) {
        LevelSlot& slot = level_slot(k);
        const std::lock_guard lock(slot.build);
        slot.level.reset();
        if (cone_pyramid_ && !cone_pyramid_->released(k)) cone_pyramid_->release_level(k, coarser_read);
    }
    const Pyramid& mip_pyramid() {
        if (!mip_pyramid_) mip_pyramid_ = std::make_unique<Pyramid>(full_image(), threads_);
        return *mip_pyramid_;
    }
    // SH of pyramid level k of the remainder (bright texels removed), at least
    // `order` bands; one projection serves every map of the call.
    // share_spectra: a cone map sums level k with the Fourier first pass, whose row spectra
    // (kept with the level) are then the projection's azimuthal sums as well.
    const ShCoefficients& remainder_sh(int k, int order, int threads, bool share_spectra = false) {
        if (!remainder_sh_ || remainder_sh_level_ != k || remainder_sh_->order < order) {
            if (share_spectra) {
                const PreparedLevel& level = cone_level(k);
                remainder_sh_ = std::make_unique<ShCoefficients>(sh_project_spectra(
                    level.width(), level.height(), order, threads, [&](int row) { return level.row_spectrum(row); },
                    ShQuadrature::TexelSolidAngle, ShSummation::Plain));
            } else {
                remainder_sh_ = std::make_unique<ShCoefficients>(sh_project(
                    cone_pyramid().level(k), order, threads, ShQuadrature::TexelSolidAngle, ShSummation::Plain));
            }
            remainder_sh_level_ = k;
        }
        return *remainder_sh_;
    }
    // Normalised Legendre recurrences for at least `order` bands (one table
    // serves every order up to its own).
    const ShLegendre& legendre(int order) {
        if (!legendre_ || legendre_->order() < order) legendre_ = std::make_unique<ShLegendre>(order);
        return *legendre_;
    }
    // The all-ones projection of level k's grid, at least `order` bands.
    const std::vector<double>& remainder_ones(int k, int order) {
        std::vector<double>& ones = remainder_ones_[k];
        if (int(ones.size()) < order) {
            const HdrImage& level = cone_pyramid().level(k);
            ones = sh_ones_projection({level.width(), level.height()}, order, legendre(order));
        }
        return ones;
    }
    // Solid-angle mean of the largest channel of level k of the remainder.
    double remainder_mean(int k) {
        auto [it, inserted] = remainder_means_.try_emplace(k, 0.0);
        // Level 0 is the bright split's remainder, whose power the split has summed.
        if (inserted)
            it->second = (k == 0 ? bright().remainder_power : max_channel_power(cone_pyramid().level(k))) / (4.0 * kPi);
        return it->second;
    }
    const ShCoefficients& sh(int order, int threads) {
        if (!sh_ || sh_->order < order)
            sh_ = std::make_unique<ShCoefficients>(sh_project(full_image(), order, threads));
        return *sh_;
    }
    // Computed, not built: the bright split waits until the plans say whether it may consume
    // the input.
    std::vector<Size> cone_level_sizes() const { return Pyramid::level_sizes({env_.width(), env_.height()}); }

private:
    const HdrImage& env_;
    const PlannerModel& model_;
    int threads_;
    std::unique_ptr<PreparedLevel> full_;
    std::unique_ptr<BrightSplit> bright_;
    std::unique_ptr<Pyramid> cone_pyramid_;
    struct LevelSlot {
        std::mutex build;
        std::unique_ptr<PreparedLevel> level;
    };
    // The slots are made once, with the pyramid (prepare_shared builds it before maps run in
    // parallel); the lock only guards making them.
    LevelSlot& level_slot(int k) {
        const std::lock_guard lock(cone_levels_mutex_);
        if (cone_levels_.empty()) {
            const int levels = cone_pyramid().levels();
            for (int i = 0; i < levels; ++i) cone_levels_.push_back(std::make_unique<LevelSlot>());
        }
        return *cone_levels_.at(std::size_t(k));
    }
    std::vector<std::unique_ptr<LevelSlot>> cone_levels_;
    std::mutex cone_levels_mutex_;
    std::unique_ptr<Pyramid> mip_pyramid_;
    std::unique_ptr<ShCoefficients> sh_;
    std::unique_ptr<ShCoefficients> remainder_sh_;
    std::map<int, double> remainder_means_;
    std::map<int, std::vector<double>> remainder_ones_;
    std::unique_ptr<ShLegendre> legendre_;
    int remainder_sh_level_ = -1;
    HdrImage* consumable_ = nullptr;
    bool consumed_ = false;
    bool release_level0_ = false;
};

// Auto's SH with the bright split for one map on an `out`-sized grid; rows where its
// truncation bound does not hold are computed by the plan's cone, which bounds them.
HdrImage run_sh_split(MapResult& r, SharedInputs& shared, MethodExecutor* executor, int threads, Size out) {
    const double n = r.request.shininess;
    const ConeSettings& settings = r.plan.cone;
    const int level = r.plan.input_level;
    const int bands = r.plan.projection_order;
    const ShSplitResult split =
        sh_split_convolve(shared.remainder_sh(level, bands, threads), shared.remainder_ones(level, bands),
                          shared.legendre(bands),
                          shared.remainder_mean(level), shared.bright().texels, n, r.plan.sh_order, out,
                          settings.texel_tolerance, settings.bright_tolerance, threads, executor);
    r.plan.bright_texels = int(shared.bright().texels.size());
    HdrImage image = split.image;
    r.clamped_texels = split.clamped;
    if (split.failed_rows.empty()) return image;
    ConeStats stats;
    const HdrImage rows = cone_convolve(shared.cone_level(r.plan.fallback_level), shared.bright().texels, n, out,
                                        settings, threads, nullptr, &stats, split.failed_rows);
    for (int row : split.failed_rows) std::copy(rows.row(row), rows.row(row) + 3 * out.width, image.row(row));
    r.refined_texels = stats.refined_texels;
    r.plan.note = "sh truncation bound not met for " + std::to_string(split.failed_values) + " channel values; their " +
                  std::to_string(split.failed_rows.size()) + " rows computed by cone at level " +
                  std::to_string(r.plan.fallback_level);
    return image;
}

// `exact` and `mipmap` maps on the executor, grouped by method and output size
// into passes of up to max_batch() maps; each map's time is its pass's share.
void run_batches(std::vector<MapResult>& results, SharedInputs& shared, MethodExecutor& executor,
                 std::vector<std::optional<HdrImage>>& batched, const RowProgress& progress) {
    std::map<std::tuple<int, int, int>, std::vector<std::size_t>> groups;
    for (std::size_t k = 0; k < results.size(); ++k) {
        const MapPlan& p = results[k].plan;
        if (p.method == Method::Exact || p.method == Method::Mipmap)
            groups[{int(p.method), p.output_size.width, p.output_size.height}].push_back(k);
    }
    for (const auto& [key, members] : groups) {
        const Size out{std::get<1>(key), std::get<2>(key)};
        const bool exact = std::get<0>(key) == int(Method::Exact);
        const std::size_t batch = std::size_t(std::max(1, executor.max_batch()));
        for (std::size_t first = 0; first < members.size(); first += batch) {
            const std::vector<std::size_t> part(members.begin() + std::ptrdiff_t(first),
                                                members.begin() + std::ptrdiff_t(std::min(members.size(), first + batch)));
            const auto start = std::chrono::steady_clock::now();
            std::vector<HdrImage> images;
            if (exact) {
                std::vector<double> ns;
                for (std::size_t k : part) ns.push_back(results[k].request.shininess);
                images = executor.exact(shared.full_image(), ns, out);
            } else {
                std::vector<std::pair<bool, double>> maps;
                for (std::size_t k : part) maps.emplace_back(results[k].request.irradiance, results[k].request.shininess);
                images = executor.mipmap(shared.mip_pyramid(), maps, out);
            }
            const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            for (std::size_t m = 0; m < part.size(); ++m) {
                batched[part[m]] = std::move(images[m]);
                results[part[m]].seconds = seconds / double(part.size());
                progress(out.height);
            }
        }
    }
}

bool same_plan(const MapResult& a, const MapResult& b) {
    return a.request.shininess == b.request.shininess && a.plan.method == b.plan.method &&
           a.plan.output_size.width == b.plan.output_size.width &&
           a.plan.output_size.height == b.plan.output_size.height &&
           a.plan.sum_size.height == b.plan.sum_size.height && a.plan.size_fixed == b.plan.size_fixed &&
           a.plan.sh_order == b.plan.sh_order &&
           a.plan.bright_split == b.plan.bright_split && a.plan.input_level == b.plan.input_level;
}

std::string percent(double v) {
    std::ostringstream s;
    s.precision(2);
    s << v * 100 << " %";
    return s.str();
}

// A lobe narrower than one of the input's texels (but not than half of one: those are planned
// as the lobe lookup) whose size the planner chose: where bilinear lookups of every grid up to
// kMaxOutputHeight would still miss the tolerance (texel-to-texel contrast such as noise), the
// map falls back to the lobe lookup (deliver_lobe_lookup), which reads the whole input.
bool may_need_lobe_lookup(const MapRequest& q, const MapPlan& p, Size input) {
    return !q.irradiance && !q.mirror && !p.size_fixed && p.lookup == MapLookup::Bilinear &&
           std::isfinite(q.shininess) && lobe_width(q.shininess) < kPi / input.height;
}

// A map below n = 1 read between its texels (no fixed size): its lookups' error along the
// sources' horizons is estimated from the whole input (horizon_step_error).
bool reads_horizon_steps(const MapRequest& q, const MapPlan& p) {
    return !q.irradiance && !q.mirror && !p.size_fixed && q.shininess < 1.0 && p.lookup == MapLookup::Bilinear &&
           p.method != Method::Mipmap;
}

// Whether 4-point resampling from a sum grid is predicted by its fourth differences: the grid
// resolves the lobe, its spacing within one lobe width; and where the input's texels are wider
// than the lobe (the map is then plateaus with transitions a lobe wide), within the sum grid's
// own rule, sum_grid_spacing lobe widths (courtyard's n = 20480 from 512x256, summed on 1024x512
// at 0.875 lobe widths, erred 5.8 % at its finer texels against a predicted 2 %).
bool resolves_for_resampling(Size sum, Size input, double n, const PlannerModel& model) {
    const double width = lobe_width(n);
    if (kPi / sum.height > width * 1.0001) return false;
    return kPi / input.height <= width || kPi / sum.height <= model.sum_grid_spacing * width * 1.0001;
}

// The grid a plan is summed on next when resampling from `sum` to `finer` would miss: twice
// as fine, or `finer` itself once that is reached.
Size next_sum_grid(Size sum, Size finer) {
    return 2 * sum.height >= finer.height ? finer : Size{2 * sum.width, 2 * sum.height};
}

// After a map is summed on its plan's sum grid: the size it is delivered at, the error of
// bilinear lookups into it and why (docs/convolution.md, "Output size"). A finer grid is
// made by 4-point resampling of the map without its bright texels (`bright`: those the plan
// summed exactly, or null), which are then added back exactly on it; where resampling would
// miss its share of tau, `sum_on` sums the plan again on the finer grid, or, where that
// happens near few texels, `sum_texels` (if given) sums just the finer grid's texels there.
// With `fine_tiles`, a finer grid is delivered as tiles of it where lookups of the sum grid
// would miss (docs/convolution.md, "Fine tiles"), when that saves at least half its texels.
// With `lobe_lookup_possible` (may_need_lobe_lookup), a whole finer grid whose lookups are
// predicted to miss their worst share between texels is not made: the caller reads the map
// through the lobe instead, as it would after making it.
using TexelSummer = std::function<void(Size, const TexelSelection&, const TexelSink& into)>;
constexpr int kFineTile = 4;  // sum-grid texels per tile side (4 against 8: studio's set ~10 % faster, 2026-12-06)
// Input texels round which a lobe under one texel is measured on its finest grid before any grid
// is summed (spot_lookup_worst): each costs a few hundred lobe lookups.
constexpr int kLobeLookupSpots = 32;
void deliver_output(MapResult& r, double tau, const PlannerModel& model, int threads,
                    const std::vector<BrightTexel>* bright, const std::function<HdrImage(Size)>& sum_on,
                    const TexelSummer& sum_texels, bool fine_tiles, bool lobe_lookup_possible) {
    MapPlan& p = r.plan;
    if (p.method == Method::Mirror || p.method == Method::Lobe) return;
    const bool resampled_fixed = p.size_fixed && (p.sum_size.width != p.output_size.width ||
                                                  p.sum_size.height != p.output_size.height);
    if (p.size_fixed && !resampled_fixed) return;  // the reference's own grid: nothing between texels counts
    const double n = r.request.shininess;
    // Makes the map on `finer`: 4-point resampling of the map summed on the current sum grid
    // (without its bright texels, which are added back exactly) where that is predicted within
    // its share of tau; else the plan is summed on a grid twice as fine and tried again from
    // there, up to summing on `finer` itself.
    // `known`: the estimate of the map as it stands, if the caller has it.
    const auto refine = [&](Size finer, const std::string& why, const LookupError* known) {
        const bool split = bright && !bright->empty();
        std::string steps;
        for (;;) {
            const double floor_value = solid_angle_mean(r.image);
            // With the split, the map without its bright texels, in place: what is resampled
            // (if the plan is summed again instead, the sum replaces it). Resampling the map with
            // its bright lobes where its own estimate passed was tried (2026-12-02): a sun's lobe
            // resampled raised sunset's predicted errors (n = 1280: 0.39 % -> 0.61 %).
            if (split) add_bright_lobes(*bright, n, floor_value, LobeOp::Subtract, r.image, threads);
            TexelLookupErrors texels;  // per texel, for the patches below (measured with e)
            const bool measure = split || !known;
            const LookupError e = measure ? estimate_lookup_error(r.image, threads, &texels) : *known;
            known = nullptr;  // the map changes if it is summed again
            // The fourth differences predict 4-point interpolation only where the sum grid
            // resolves the lobe (its spacing within one lobe width; a Gaussian sampled coarser
            // aliases); a grid capped at a coarser input's resolution is summed again instead.
            const bool resolved = resolves_for_resampling(p.sum_size, p.input_size, n, model);
            const auto resample = [&] {
                if (split) {
                    const BrightLobes lobes(*bright, n, finer, floor_value, LobeOp::AddClamped);
                    r.image = resample_cubic(r.image, finer, threads, &r.clamped_texels, &lobes);
                } else {
                    r.image = resample_cubic(r.image, finer, threads, &r.clamped_texels);
                }
            };
            const std::string resampled = "; resampled 4-point from " + to_string(p.sum_size);
            const std::string added = split ? ", bright texels added exactly" : "";
            if (resolved && e.cubic_rms <= model.resample_share * tau &&
                e.cubic_worst <= model.resample_worst_share * tau) {
                resample();
                p.predicted_error += e.cubic_rms;
                p.size_reason = why + steps + resampled + " (predicted " + percent(e.cubic_rms) + ")" + added;
                break;
            }
            const Size next = next_sum_grid(p.sum_size, finer);
            if (resolved && sum_texels) {
                // Resampling misses its share near few texels (a small bright light, an edge):
                // the finer grid's texels there are summed exactly, if that is fewer texels than
                // summing the next grid would be.
                const ResamplePatches patches =
                    plan_resample_patches(r.image, model.resample_share * tau, model.resample_worst_share * tau,
                                          threads, measure ? &texels : nullptr);
                const TexelSelection selection = fine_texels_near(patches.texels, p.sum_size, finer, threads);
                if (2 * selection.texels <= static_cast<long long>(next.width) * next.height) {
                    resample();
                    sum_texels(finer, selection, [&](int row, int col, const float* rgb) {
                        std::copy_n(rgb, 3, r.image.row(row) + 3 * col);
                    });
                    r.patched_texels = selection.texels;
                    p.predicted_error += patches.remaining_rms;
                    p.size_reason = why + steps + resampled + " (predicted " + percent(patches.remaining_rms) +
                                    " RMS, " + percent(patches.remaining_worst) + " worst)" + added + ", and summed on " +
                                    to_string(finer) + " at the " + std::to_string(selection.texels) +
                                    " texels near the " + std::to_string(patches.count) + " of " +
                                    to_string(p.sum_size) + " where it would err more (" + percent(e.cubic_rms) +
                                    " RMS, " + percent(e.cubic_worst) + " worst)";
                    break;
                }
            }
            steps += "; summed on " + to_string(next) + " (" +
                     (resolved ? "4-point resampling from " + to_string(p.sum_size) + " would err " +
                                     percent(e.cubic_rms) + " RMS, " + percent(e.cubic_worst) + " worst)"
                               : to_string(p.sum_size) + " does not resolve the lobe)");
            r.image = sum_on(next);
            p.sum_size = next;
            if (next.height == finer.height) {
                p.size_reason = why + steps;
                break;
            }
        }
        p.output_size = finer;
    };
    if (resampled_fixed) {
        refine(p.output_size, "fixed by the request", nullptr);
        return;
    }
    TexelLookupErrors with_bright;  // per texel, for the fine tiles
    const LookupError e = estimate_lookup_error(r.image, threads, fine_tiles ? &with_bright : nullptr);
    const auto within = [&](int factor) {
        const LookupError::Bilinear b = e.finer(factor);
        return b.rms <= model.output_share * tau && b.worst <= model.output_worst_share * tau;
    };
    int factor = 1;
    while (!within(factor) && factor * 2 <= model.max_refinement &&
           p.sum_size.height * factor * 2 <= kMaxOutputHeight)
        factor *= 2;
    const std::string estimate = "bilinear lookups between texels of " + to_string(p.sum_size) + " err " +
                                 percent(e.bilinear_rms) + " RMS, " + percent(e.bilinear_worst) + " worst";
    // The finer grid only in tiles where lookups of the sum grid would miss their share: the
    // sum grid is delivered as it is (bright texels in) and the tiles' texels are made as
    // refine() makes the whole grid's, 4-point resampling without the bright texels, those added
    // back exactly, and exact sums where resampling would miss. Only on that route; a map that
    // refine() would sum again on a finer grid gets the whole grid.
    TileLookupWorst tiles_worst;  // deliver_tiles: the worst lookups measured in its tiles
    const auto deliver_tiles = [&](int f) {
        const Size finer{p.sum_size.width * f, p.sum_size.height * f};
        // Outside the tiles the sum grid's lookups keep what the lookups' share leaves beside
        // the resampling's inside them (the whole finer grid used little of it).
        const double outside_share = std::max(0.5 * model.output_share, model.output_share - model.resample_share);
        // The worst budget halved: the sum grid's second differences under-predict next to a
        // lobe it barely resolves (courtyard's n = 20480 on 1024x512 measured 6 % against a 4 %
        // budget), and a lookup there is what a highlight shows.
        // Tiles of kFineTile texels, or of 2 where the grid's sides are only even (2 W x 2 H for
        // an odd input width W, planner sum_grid_size).
        const int tile = FineTiles::fits(p.sum_size.width, p.sum_size.height, kFineTile) ? kFineTile : 2;
        const FineTilePlan tp = plan_fine_tiles(r.image, f, tile, outside_share * tau,
                                                0.5 * model.output_worst_share * tau, threads, &with_bright);
        const long long side = tile * f + 1;
        // At most half the texels of the whole grid `f` times finer. Finer than a whole grid
        // may go (max_refinement), at most a third of that grid's: such tiles then take less
        // memory than it, and on a map wider than a few blocks they pack within f times the sum
        // grid's rows, so a renderer does not expand them to their whole grid
        // (render/tiled_map.hpp; 8x of 512x256 would be a 4096x2048 texture).
        const long long limit = std::min(f, model.max_refinement);
        const long long whole = static_cast<long long>(p.sum_size.width) * p.sum_size.height * limit * limit;
        const long long share = f > model.max_refinement ? 3 : 2;
        if (tp.tiles == 0 || share * tp.tiles * side * side > whole) return false;
        if (!resolves_for_resampling(p.sum_size, p.input_size, n, model)) return false;
        const bool split = bright && !bright->empty();
        HdrImage base;  // the map as summed, delivered as it is (with the split, r.image is changed below)
        if (split) base = r.image;
        const auto give_up = [&] {
            if (split) r.image = std::move(base);
            return false;
        };
        const double floor_value = solid_angle_mean(r.image);
        if (split) add_bright_lobes(*bright, n, floor_value, LobeOp::Subtract, r.image, threads);
        TexelLookupErrors without_texels;
        const LookupError without = split ? estimate_lookup_error(r.image, threads, &without_texels) : e;
        const bool cubic_ok = without.cubic_rms <= model.resample_share * tau &&
                              without.cubic_worst <= model.resample_worst_share * tau;
        ResamplePatches patches;
        TexelSelection patch;
        if (!cubic_ok) {
            // Exact sums where resampling would miss, as refine() decides them: only if that is
            // at most half the texels of summing the next grid whole (else the whole grid).
            if (!sum_texels) return give_up();
            patches = plan_resample_patches(r.image, model.resample_share * tau, model.resample_worst_share * tau,
                                            threads, split ? &without_texels : &with_bright);
            const TexelSelection near = fine_texels_near(patches.texels, p.sum_size, finer, threads);
            const Size next = next_sum_grid(p.sum_size, finer);
            if (2 * near.texels > static_cast<long long>(next.width) * next.height) return give_up();
            patch = intersect(near, fine_tile_texels(tp, p.sum_size));
        }
        // Read no more: freed before the tiles and their exact texels take memory (24 bytes a
        // texel of the sum grid, 675 MiB at 7680x3840).
        without_texels = TexelLookupErrors{};
        std::optional<BrightLobes> lobes;
        if (split) lobes.emplace(*bright, n, finer, floor_value, LobeOp::AddClamped);
        r.fine = make_fine_tiles(r.image, tp, threads, &r.clamped_texels, lobes ? &*lobes : nullptr);
        if (patch.texels > 0) {
            sum_texels(finer, patch, [&](int row, int col, const float* rgb) {
                set_fine_texel(r.fine, p.sum_size, col, row, rgb);
            });
            r.patched_texels = patch.texels;
        }
        if (split) r.image = std::move(base);
        // Lookups outside the tiles read the sum grid (its unmarked texels' estimate); inside,
        // the finer grid's (the sum grid's RMS estimate scaled, as for the whole finer grid):
        // disjoint regions, so their squares add. The worst inside is measured on the tiles'
        // texels (tile_lookup_worst).
        const double inside = e.finer(f).rms;
        tiles_worst = tile_lookup_worst(r.image, r.fine, floor_value);
        const double inside_worst = tiles_worst.worst();
        const double resampled = cubic_ok ? without.cubic_rms : patches.remaining_rms;
        p.lookup_error = std::sqrt(tp.remaining_rms * tp.remaining_rms + inside * inside);
        p.lookup_worst = std::max(tp.remaining_worst, inside_worst);
        p.predicted_error += p.lookup_error + resampled;
        p.output_size = p.sum_size;
        p.size_reason = estimate + "; the sum grid, with tiles of " + std::to_string(tile) + "x" +
                        std::to_string(tile) + " texels " + std::to_string(f) + "x finer (" + to_string(finer) +
                        ") at " + std::to_string(r.fine.count()) + " of " + std::to_string(tp.kept.size()) +
                        " tiles, near the " + std::to_string(tp.marked) + " texels where lookups err more (" +
                        percent(tp.remaining_rms) + " RMS, " + percent(tp.remaining_worst) +
                        " worst elsewhere)" + (within(f) ? "" : " (the finest grid allowed)") +
                        "; their texels resampled 4-point (predicted " + percent(resampled) + ")" +
                        (split ? ", bright texels added exactly" : "") +
                        (patch.texels > 0 ? ", and " + std::to_string(patch.texels) + " of them summed exactly" : "");
        return true;
    };
    // Where kMaxOutputHeight stops the whole grid short of the tolerance itself (the map would
    // be refused), tiles may go on to kMaxTiledHeight rows: 3000x1500's n = 1e5 sums on the
    // input's grid, and 2x finer is 3000 rows (2.8 % RMS predicted, refused, before).
    // Only where the lookups are most of the miss (a method's own error, e.g. a low --sh-order,
    // is not mended by finer tiles), and not for a lobe that may take the lobe lookup instead
    // (exact; what such a map did before).
    const bool capped = factor * 2 <= model.max_refinement && p.sum_size.height * factor * 2 > kMaxOutputHeight &&
                        !lobe_lookup_possible;
    const auto over_tolerance = [&](int f) {
        const double lookups = e.finer(f).rms;
        return p.predicted_error + lookups > tau && lookups >= p.predicted_error;
    };
    int tile_factor = factor;
    if (fine_tiles && capped)
        while (over_tolerance(tile_factor) && tile_factor * 2 <= model.max_refinement &&
               p.sum_size.height * tile_factor * 2 <= kMaxTiledHeight)
            tile_factor *= 2;
    if (tile_factor > 1 && fine_tiles) {
        // What deliver_tiles changes, kept to go back to.
        struct Delivered {
            MapPlan plan;
            FineTiles fine;
            long long clamped, patched, refined;
        };
        const auto take = [&] {
            return Delivered{p, std::move(r.fine), r.clamped_texels, r.patched_texels, r.refined_texels};
        };
        const auto put_back = [&](Delivered d) {
            p = std::move(d.plan);
            r.fine = std::move(d.fine);
            r.clamped_texels = d.clamped;
            r.patched_texels = d.patched;
            r.refined_texels = d.refined;
        };
        const Delivered before = take();
        if (deliver_tiles(tile_factor)) {
            // Tiles twice as fine while the lookups measured between their texels miss the worst
            // share, up to max_tile_refinement (a few tiles 8x finer cost less than a whole grid
            // 4x). Not for the poles' clamp: at 4x its cap's radius is an eighth of the sum
            // grid's spacing, and halving it costs every pole tile four times the texels.
            // And while the map misses the tolerance through its lookups, up to kMaxTiledHeight
            // rows (where the whole grid's kMaxOutputHeight stopped the tiles short of it).
            const auto finer_tiles = [&](int f) {
                if (f > model.max_tile_refinement) return false;
                const bool worst = tiles_worst.between > model.output_worst_share * tau &&
                                   p.sum_size.height * f <= kMaxOutputHeight;
                const bool over = capped && p.predicted_error > tau && p.lookup_error >= 0.5 * p.predicted_error &&
                                  p.sum_size.height * f <= kMaxTiledHeight;
                return worst || over;
            };
            for (int f = 2 * tile_factor; finer_tiles(f); f *= 2) {
                Delivered coarser = take();
                put_back(before);
                if (!deliver_tiles(f)) {
                    put_back(std::move(coarser));
                    break;
                }
            }
            return;
        }
        put_back(before);
    }
    p.lookup_error = e.finer(factor).rms;
    p.lookup_worst = e.finer(factor).worst;
    p.predicted_error += p.lookup_error;
    if (factor == 1) {
        p.size_reason = "the lobe's sum grid: " + estimate + (within(1) ? "" : " (no finer grid allowed)");
        return;
    }
    if (lobe_lookup_possible && e.between_worst / (double(factor) * factor) > model.output_worst_share * tau) {
        // The finer grid's worst is at least this (below), so the caller will read the map
        // through the lobe: summing it (n = 1e5 from 1024x512 on 4096x2048: 2.6 s) is skipped.
        p.size_reason = estimate + ", " + std::to_string(factor) + "x finer: " + percent(p.lookup_worst) +
                        " worst (the finest grid allowed, not made)";
        return;
    }
    refine({p.sum_size.width * factor, p.sum_size.height * factor},
           estimate + ", " + std::to_string(factor) + "x finer: " + percent(p.lookup_error) +
               (within(factor) ? "" : " (the finest grid allowed)"),
           &e);
    // The clamp measured on the finer map itself: scaled, it is the secant of a slope that
    // the finer grid's first row is much closer to.
    p.lookup_worst = std::max(e.between_worst / (double(factor) * factor),
                              pole_clamp_worst(r.image, solid_angle_mean(r.image)));
    if (p.sum_size.height == p.output_size.height) {
        // Summed again on the finer grid: its own differences measure its lookups (the coarse
        // grid's, scaled, under-predict where it did not resolve the lobe).
        const LookupError fine = estimate_lookup_error(r.image, threads);
        p.lookup_worst = std::max(p.lookup_worst, fine.bilinear_worst);
        if (fine.bilinear_rms > p.lookup_error) {
            p.predicted_error += fine.bilinear_rms - p.lookup_error;
            p.lookup_error = fine.bilinear_rms;
            p.size_reason += "; measured on it: " + percent(fine.bilinear_rms);
        }
    }
}

// Computes map k with `threads` threads (results[k].image, .seconds, ...).
using MapRunner = std::function<void(std::size_t k, int threads)>;

// Builds every shared input the maps in `to_run` read, each with all threads, before maps run
// concurrently: SharedInputs builds lazily and is not thread-safe, and a build started inside
// a concurrent map would run on one thread only.
void prepare_shared(SharedInputs& shared, const std::vector<MapResult>& results,
                    const std::vector<std::size_t>& to_run, int threads) {
    // Levels of the remainder some cone map sums with the Fourier first pass (cone.cpp).
    std::set<int> spectra_levels;
    for (std::size_t k : to_run) {
        const MapPlan& p = results[k].plan;
        if (p.method == Method::Cone &&
            FourierFirstPass::used_by_cone(p.cone, p.input_size.width, p.input_size.height, p.sum_size.width))
            spectra_levels.insert(p.input_level);
    }
    int max_sh_order = 0;
    for (std::size_t k : to_run) {
        const MapPlan& p = results[k].plan;
        switch (p.method) {
            case Method::Exact:
                shared.full_level();
                break;
            case Method::Mipmap:
                shared.mip_pyramid();
                break;
            case Method::Cone:
                shared.bright();
                shared.cone_level(p.input_level);
                break;
            case Method::Sh:
                if (p.bright_split) {
                    shared.bright();
                    shared.remainder_sh(p.input_level, p.projection_order, threads,
                                        spectra_levels.count(p.input_level) > 0);
                    shared.remainder_ones(p.input_level, p.projection_order);
                    shared.legendre(p.projection_order);
                    shared.remainder_mean(p.input_level);
                    // Not the fallback level (for rows whose SH bound fails): most maps have none,
                    // and laying out a level costs as much as the map at small sizes.
                } else {
                    max_sh_order = std::max(max_sh_order, p.sh_order);
                }
                break;
            case Method::Mirror:
            case Method::Lobe:
            case Method::Auto:
                break;
        }
    }
    if (max_sh_order > 0) shared.sh(max_sh_order, threads);
}

// Runs the maps concurrently, one per thread, longest predicted first (LPT scheduling), so
// the serial parts of one map (tables, set-up, the tail of its row loop) overlap with the
// work of others instead of leaving threads idle. A map predicted to take more than
// 1 / (2 * threads) of the whole cannot be balanced among the others: such maps run first,
// one after another, each with every thread. Each map's result does not depend on how many
// threads computed it (every row is computed by one thread).
void run_maps_in_parallel(const std::vector<MapResult>& results, std::vector<std::size_t> to_run,
                          const PlannerModel& model, int threads, const MapRunner& run_map) {
    const auto seconds = [&](std::size_t k) { return predicted_seconds(results[k].plan, model); };
    std::stable_sort(to_run.begin(), to_run.end(),
                     [&](std::size_t a, std::size_t b) { return seconds(a) > seconds(b); });
    double total = 0;
    for (std::size_t k : to_run) total += seconds(k);
    std::size_t first_shared = 0;
    while (first_shared < to_run.size() && seconds(to_run[first_shared]) * 2.0 * threads > total) {
        run_map(to_run[first_shared], threads);
        ++first_shared;
    }
    const int rest = int(to_run.size() - first_shared);
    parallel_for(rest, threads, [&](int i) { run_map(to_run[first_shared + std::size_t(i)], 1); });
}

}  // namespace

namespace {

std::vector<MapResult> convolve_map(const HdrImage& env, HdrImage* consumable, const std::vector<MapRequest>& maps,
                                    const Options& options) {
    const int threads = options.threads > 0 ? options.threads : hardware_threads();
    const PlannerModel model;
    const Size input_size{env.width(), env.height()};  // env may be handed to the bright split below
    SharedInputs shared(env, model, threads);
    // Planning needs the pyramid's sizes only; the size of level 0 is the input's.
    const std::vector<MapPlan> plans =
        plan_maps(input_size, maps, options, [&] { return shared.cone_level_sizes(); }, model);
    bool reads_whole = options.executor != nullptr, reads_level0 = false;
    for (std::size_t k = 0; k < plans.size(); ++k) {
        const MapPlan& p = plans[k];
        if (p.method == Method::Exact || p.method == Method::Mipmap || p.method == Method::Mirror ||
            p.method == Method::Lobe || reads_horizon_steps(maps[k], p) ||
            (p.method == Method::Sh && !p.bright_split) || may_need_lobe_lookup(maps[k], p, input_size))
            reads_whole = true;
        if ((p.method == Method::Cone && p.input_level == 0) ||
            (p.method == Method::Sh && p.bright_split && (p.input_level == 0 || p.fallback_level == 0)))
            reads_level0 = true;
    }
    if (consumable && !reads_whole) shared.allow_consuming(consumable);
    if (!reads_level0) shared.release_level0_after_pyramid();
    std::vector<MapResult> results;
    for (std::size_t k = 0; k < maps.size(); ++k) results.push_back({maps[k], plans[k], {}, {}, 0, 0, 0, 0, 0, ""});

    long long total_rows = 0;
    for (const MapResult& r : results) total_rows += r.plan.sum_size.height;
    std::atomic<long long> done_rows{0};
    const RowProgress progress = [&](long long rows) {
        const long long d = done_rows.fetch_add(rows) + rows;
        if (options.progress) options.progress(d, total_rows);
    };

    // With an executor, `exact` and `mipmap` maps of one output size share passes.
    std::vector<std::optional<HdrImage>> batched(results.size());
    if (options.executor) run_batches(results, shared, *options.executor, batched, progress);

    // Identical lobe, size and plan (irradiance and phong_1): computed once, copied after.
    std::vector<std::optional<std::size_t>> same_as(results.size());
    std::vector<std::size_t> to_run;
    for (std::size_t k = 0; k < results.size(); ++k) {
        if (batched[k]) {
            results[k].image = std::move(*batched[k]);
            to_run.push_back(k);  // delivered below, not summed again
            continue;
        }
        for (std::size_t e = 0; e < k && !same_as[k]; ++e)
            if (!batched[e] && !same_as[e] && same_plan(results[e], results[k])) same_as[k] = e;
        if (same_as[k])
            results[k].plan.shares_with = results[*same_as[k]].request.label;
        else
            to_run.push_back(k);
    }

    // The plan's method summed on `grid` (its sum grid, or a finer one; output_grid.hpp).
    const auto sum_on = [&](MapResult& r, Size grid, int map_threads, const RowProgress& rows) {
        const double n = r.request.shininess;
        switch (r.plan.method) {
            case Method::Exact:
                return exact_convolve(shared.full_level(), n, grid, map_threads, rows);
            case Method::Sh: {
                if (r.plan.bright_split) {
                    HdrImage image = run_sh_split(r, shared, options.executor, map_threads, grid);
                    rows(grid.height);
                    return image;
                }
                HdrImage image = sh_convolve(shared.sh(r.plan.sh_order, map_threads), input_size, n,
                                             r.plan.sh_order, grid, map_threads, &r.clamped_texels, options.executor);
                rows(grid.height);
                return image;
            }
            case Method::Cone: {
                ConeStats stats;
                r.plan.bright_texels = int(shared.bright().texels.size());
                const PreparedLevel& level = shared.cone_level(r.plan.input_level);
                std::unique_ptr<ConeSumsBackend> backend;
                if (options.executor) backend = options.executor->cone_sums(level, grid, n, r.plan.cone);
                HdrImage image = cone_convolve(level, shared.bright().texels, n, grid, r.plan.cone, map_threads, rows,
                                               &stats, {}, backend.get());
                r.refined_texels += stats.refined_texels;
                r.cone_cutoff_energy = stats.cutoff_energy;
                r.cone_first_pass = stats.fourier_first_pass ? "fourier" : "direct";
                return image;
            }
            case Method::Mipmap: {
                HdrImage image = mipmap_convolve(shared.mip_pyramid(), r.request.irradiance, n, grid.width, grid.height);
                rows(grid.height);
                return image;
            }
            case Method::Mirror: {
                HdrImage image = filter_to_footprint(shared.full_image(), grid, map_threads);
                rows(grid.height);
                return image;
            }
            case Method::Lobe: {
                HdrImage image = resample_lobe(shared.full_image(), grid.width, grid.height, n, map_threads);
                rows(grid.height);
                return image;
            }
            case Method::Auto:
                break;
        }
        throw RuntimeError("internal: a plan must name a concrete method");
    };
    const RowProgress no_progress = [](long long) {};
    // Maps still to run per level of the remainder they read (cone, SH with the split): a
    // level is freed when its last map is done.
    // An SH map with the split reads its projection's level and, for rows whose bound fails and
    // texels of a finer grid, its cone's fallback level.
    std::map<int, int> level_readers;
    const auto levels_read = [](const MapPlan& p) {
        std::vector<int> levels;
        if (p.method == Method::Cone) levels.push_back(p.input_level);
        if (p.method == Method::Sh && p.bright_split) {
            levels.push_back(p.input_level);
            if (p.fallback_level != p.input_level) levels.push_back(p.fallback_level);
        }
        return levels;
    };
    for (std::size_t k : to_run)
        if (!batched[k])
            for (int level : levels_read(results[k].plan)) ++level_readers[level];
    std::mutex level_readers_mutex;
    const MapRunner run_map = [&](std::size_t k, int map_threads) {
        MapResult& r = results[k];
        // The levels this map's plan reads, before the lobe-lookup fallback below may change it.
        const std::vector<int> mine = levels_read(r.plan);
        const auto start = std::chrono::steady_clock::now();
        // A lobe under one input texel whose exact map, on the finest grid this plan may deliver,
        // already misses the worst-texel share round the input's roughest texels: the lobe lookup
        // at once, no grid summed (n = 5e4-1e5 from 1024x512 summed 2048x1024 only to fall back,
        // 0.4-0.7 s). A spot that finds nothing decides nothing: the map is summed as planned.
        double spot_worst = 0;
        Size finest = r.plan.sum_size;
        if (!batched[k] && may_need_lobe_lookup(r.request, r.plan, input_size)) {
            const int most = std::max(model.max_refinement, model.max_tile_refinement);
            int f = 1;
            while (2 * f <= most && r.plan.sum_size.height * 2 * f <= kMaxOutputHeight) f *= 2;
            finest = {r.plan.sum_size.width * f, r.plan.sum_size.height * f};
            spot_worst = spot_lookup_worst(shared.full_image(), r.request.shininess, finest, kLobeLookupSpots, map_threads);
        }
        const bool lobe_at_once = spot_worst > model.output_worst_share * options.tolerance;
        if (lobe_at_once)
            progress(r.plan.sum_size.height);
        else if (!batched[k])
            r.image = sum_on(r, r.plan.sum_size, map_threads, progress);
        if (!batched[k] && !lobe_at_once) {
            // The grid is summed: a level no other map will read keeps only its planes through the
            // delivery, whose lookup estimates and tiles then have that memory (the phase layouts
            // of an 8192x4096 level are two copies of it, 768 MiB). A finer grid's texels summed
            // later (patches, a grid summed again) lay the level out for their grid, as they did
            // before; where their layout is the one freed (a grid as wide as the level or wider,
            // whose finer grids share its column phases) it is made again whole: time, not peak.
            const std::lock_guard lock(level_readers_mutex);
            for (int level : mine)
                if (level_readers[level] == 1) shared.release_cone_layouts(level);
        }
        const bool split = r.plan.method == Method::Cone || (r.plan.method == Method::Sh && r.plan.bright_split);
        // Texels of a finer grid, summed by the plan's cone (an SH plan's is the one for the rows
        // its bound fails).
        const TexelSummer sum_texels = [&](Size grid, const TexelSelection& selection, const TexelSink& into) {
            const PreparedLevel& level =
                shared.cone_level(r.plan.method == Method::Cone ? r.plan.input_level : r.plan.fallback_level);
            std::unique_ptr<ConeSumsBackend> backend;
            if (options.executor) backend = options.executor->cone_sums(level, grid, r.request.shininess, r.plan.cone);
            ConeStats stats;
            cone_convolve(level, shared.bright().texels, r.request.shininess, grid, r.plan.cone, map_threads,
                          no_progress, &stats, selection.rows, backend.get(), &selection.runs, &into);
            r.refined_texels += stats.refined_texels;
        };
        const double own_error = r.plan.predicted_error;  // the method's, before lookups count
        if (!lobe_at_once)
            deliver_output(r, options.tolerance, model, map_threads,
                           split ? &shared.bright().texels : nullptr,
                           [&](Size grid) { return sum_on(r, grid, map_threads, no_progress); },
                           split ? sum_texels : TexelSummer{}, options.fine_tiles,
                           may_need_lobe_lookup(r.request, r.plan, input_size));
        if (reads_horizon_steps(r.request, r.plan)) {
            // Below n = 1, what lookups miss along each source's horizon (horizon_step_error; a
            // 1e5 sun on 256x128 gave phong_0 2.9 % RMS and 81 % worst off-grid where the second
            // differences predicted 0.7 %). While that keeps the map over the tolerance it is
            // summed again on twice the grid (the steps' share falls as sqrt(h), the rest as h^2),
            // up to twice the input's height and kMaxOutputHeight; what is left is reported.
            MapPlan& p = r.plan;
            LookupError step = horizon_step_error(shared.full_image(), r.image, r.request.shininess);
            double with_step = std::hypot(p.lookup_error, step.bilinear_rms);
            p.predicted_error += with_step - p.lookup_error;
            p.lookup_error = with_step;
            p.lookup_worst = std::max(p.lookup_worst, step.bilinear_worst);
            std::string steps;
            const int cap = std::min(2 * input_size.height, kMaxOutputHeight);
            while (p.predicted_error > options.tolerance && 2 * p.output_size.height <= cap &&
                   (p.method == Method::Cone || p.method == Method::Exact)) {
                const Size next{2 * p.output_size.width, 2 * p.output_size.height};
                steps += "; summed on " + to_string(next) + " (lookups of " + to_string(p.output_size) + " with the steps: " +
                         percent(p.lookup_error) + " RMS)";
                r.image = sum_on(r, next, map_threads, no_progress);
                r.fine = FineTiles{};
                r.patched_texels = 0;
                p.sum_size = p.output_size = next;
                const LookupError base = estimate_lookup_error(r.image, map_threads);
                step = horizon_step_error(shared.full_image(), r.image, r.request.shininess);
                p.lookup_error = std::hypot(base.bilinear_rms, step.bilinear_rms);
                p.lookup_worst = std::max(base.bilinear_worst, step.bilinear_worst);
                p.predicted_error = own_error + p.lookup_error;
            }
            p.size_reason += steps + "; the horizon's step of n < 1 adds " + percent(step.bilinear_rms) + " RMS, " +
                             percent(step.bilinear_worst) + " worst to lookups between texels of " +
                             to_string(p.output_size);
        }
        // The lookups' share decides (a method's own error, e.g. a --sh-order too low, is not
        // mended by reading the input through the lobe, and is reported as it is).
        if (lobe_at_once ||
            (may_need_lobe_lookup(r.request, r.plan, input_size) &&
             ((r.plan.predicted_error > options.tolerance && r.plan.lookup_error >= 0.5 * r.plan.predicted_error) ||
              r.plan.lookup_worst > model.output_worst_share * options.tolerance))) {
            // Bilinear lookups of every grid tried miss the tolerance, or their worst its share
            // (the 5 % worst texel): the lobe lookup instead (exact to rounding, at the price of
            // more texels visited per read than for a lobe under half a texel: ~170-290 at one
            // texel's width).
            MapPlan& p = r.plan;
            const std::string tried = p.size_reason;
            const double missed = p.lookup_error;
            r.image = filter_to_footprint(shared.full_image(), input_size, map_threads);  // the input's texels
            r.fine = FineTiles{};
            p.method = Method::Mirror;
            p.lookup = MapLookup::Lobe;
            p.input_level = 0;
            p.input_size = p.output_size = p.sum_size = input_size;
            p.cutoff_cos = -1;
            p.bright_split = false;
            p.sh_order = 0;
            const double missed_worst = p.lookup_worst;
            p.lookup_error = p.lookup_worst = 0;
            p.predicted_error = 0;
            p.predicted_cost = double(input_size.width) * input_size.height;
            p.bright_texels = 0;
            p.note = "bilinear lookups of the grids tried missed the tolerance: read through the lobe instead";
            r.refined_texels = r.patched_texels = r.clamped_texels = 0;
            const std::string lead = "the input's grid, read through the lobe (lookup \"lobe\"): the lobe is narrower "
                                     "than the input's texel spacing and bilinear lookups ";
            p.size_reason = lobe_at_once ? lead + "of the finest grid allowed, " + to_string(finest) + ", would err " +
                                               percent(spot_worst) + " worst round the input's " +
                                               std::to_string(kLobeLookupSpots) +
                                               " roughest texels (the exact sums there; no grid summed)"
                                         : lead + "of the grids tried would err " + percent(missed) + " RMS, " +
                                               percent(missed_worst) + " worst (" + tried + ")";
        }
        r.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (!batched[k]) {
            // All of this map's levels counted down first (its own fallback level must not keep
            // its input level's coarser neighbour alive), then the levels no map reads any more
            // freed, under the count's lock: the decision that a coarser level is still read and
            // the release it guards must not interleave with another map's release (a level built
            // from one released meanwhile). Releasing is a free, or one halving when a coarser
            // level is still to be read and not built yet.
            const std::lock_guard lock(level_readers_mutex);
            for (int level : mine) --level_readers[level];
            for (int level : mine) {
                if (level_readers[level] != 0) continue;
                const bool coarser_read = std::any_of(level_readers.upper_bound(level), level_readers.end(),
                                                      [](const auto& readers) { return readers.second > 0; });
                shared.release_cone_level(level, coarser_read);
            }
        }
    };
    if (options.executor || threads == 1) {
        // The GPU engine owns one context, driven from this thread: maps in order.
        for (std::size_t k : to_run) run_map(k, threads);
    } else {
        prepare_shared(shared, results, to_run, threads);
        run_maps_in_parallel(results, to_run, model, threads, run_map);
    }
    for (std::size_t k = 0; k < results.size(); ++k)
        if (same_as[k]) {
            const MapResult& original = results[*same_as[k]];
            MapPlan& p = results[k].plan;
            results[k].image = original.image;
            results[k].fine = original.fine;
            // The whole plan as it ran (its size, and a fallback to the lobe lookup with its method
            // and lookup), but the label it shares with.
            const std::string shares = p.shares_with;
            p = original.plan;
            p.shares_with = shares;
            progress(p.sum_size.height);
        }
    for (const MapResult& r : results)
        if (r.image.width() != r.plan.output_size.width || r.image.height() != r.plan.output_size.height)
            throw RuntimeError("internal: " + r.request.label + " was made at " + to_string({r.image.width(), r.image.height()}) +
                               ", its plan says " + to_string(r.plan.output_size));
    return results;
}

}  // namespace

std::vector<MapResult> convolve(const HdrImage& environment, const std::vector<MapRequest>& maps,
                                const Options& options) {
    return convolve_map(environment, nullptr, maps, options);
}

std::vector<MapResult> convolve(HdrImage&& environment, const std::vector<MapRequest>& maps, const Options& options) {
    return convolve_map(environment, &environment, maps, options);
}

}  // namespace glint::convolution
