// The radiance convolution engine: one API over every method (docs/convolution.md).
// Input: an equirect HDR map. Output: the irradiance
// map E_d and the Phong reflection maps E_s^n of docs/conventions.md.
#pragma once

#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "appliance/core/equirect.hpp"
#include "appliance/core/fine_tiles.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::convolution {

// Mirror is not a --method: a MapRequest::make_mirror() map is planned as one by every method.
// Lobe is not one either: auto's plan at a fixed size for a lobe so narrow that the cone's
// cut-off would hold few input texel centres (under 1.5 spacings), E at each output texel's
// centre summed over the input texels near it (sample_lobe).
enum class Method { Auto, Exact, Cone, Sh, Mipmap, Mirror, Lobe };

std::string to_string(Method m);
std::optional<Method> parse_method(const std::string& name);

struct Size {
    int width = 0, height = 0;
};

// "WxH", as the CLI takes and reports sizes.
std::string to_string(Size s);

// One wanted map. The irradiance map is, by the conventions, the n = 1 lobe
// looked up with the normal; it is its own request so files are named for it.
struct MapRequest {
    bool irradiance = false;
    bool mirror = false;     // n = infinity: the environment filtered to the output's texels
    double shininess = 1.0;  // n >= 0; 1 for the irradiance map; +infinity for the mirror
    std::string label;       // "irradiance" or "phong_<n as given>", the file stem
    std::optional<Size> size;  // fixes this map's output size (before Options::size)

    static MapRequest make_irradiance();
    static MapRequest make_phong(double n, const std::string& as_given);
    static MapRequest make_mirror();
};

class MethodExecutor;  // methods.hpp: where the sums run (the GPU engine, gpu/gpu_engine.hpp)

struct Options {
    Method method = Method::Auto;
    double tolerance = 0.01;       // weighted relative RMS the planner aims at
    std::optional<Size> size;      // fixes every output map's size
    int sh_order = 0;              // 0: planner's choice (or the default for --method sh)
    int threads = 0;               // 0: all hardware threads
    // Called with (units done, units total) as work completes; may be called from
    // worker threads. Units are output rows.
    std::function<void(long long, long long)> progress;
    // Runs `exact`, the cone's sums and `mipmap` elsewhere (the GPU engine);
    // null: on the CPU. Planning and everything else stay the same.
    MethodExecutor* executor = nullptr;
    // A map that needs a finer grid than it was summed on (without a fixed size) is delivered as
    // its sum grid plus fine tiles where bilinear lookups of that grid would miss the tolerance
    // (MapResult::fine; docs/convolution.md, "Fine tiles"), when those tiles hold at most half
    // of the finer grid's texels. Off: the whole finer grid.
    bool fine_tiles = false;
};

// How the cone method runs for one map (methods.hpp, cone_convolve); the planner
// sets it from the tolerance and the lobe.
struct ConeSettings {
    double cutoff_energy = 1e-2;  // lobe energy dropped outside the first cone
    double texel_tolerance = 1e-2;  // bound on the cut-off error of each output texel
    double bright_tolerance = 1e-2; // the bright texels' dropped terms together, over the smallest output (BrightScatter)
    // Rows near the poles may read merged columns whose azimuthal arc stays
    // within this many radians (0: never; see PolarColumns in lobe_sum.hpp).
    double max_texel_arc = 0;
    // ... and where a row's values are rough, merged arc x roughness within this
    // (polar_merge_factors in lobe_sum.hpp; infinity: no such limit).
    double max_arc_roughness = std::numeric_limits<double>::infinity();
    // The first pass by Fourier transforms along the rows where it applies (fourier_pass.hpp):
    // the same sums, to rounding. Off: the direct sums (for comparisons).
    bool fourier_first_pass = true;
    // The lobe energy the Fourier first pass drops (at most cutoff_energy).
    double fourier_cutoff_energy = 1e-6;
};

// What was decided for one map, and why it is expected to be within tolerance.
// The planner (planner.hpp) fills in all of it except what running the map
// finds out (bright_texels, shares_with, note); the engines only carry it out.
struct MapPlan {
    Method method = Method::Exact;
    int input_level = 0;             // pyramid level read (0 = the input map)
    Size input_size;                 // size of that level
    Size output_size;                // the map delivered
    // The grid the method sums on. Without a fixed size the planner sets both to the grid the
    // lobe needs and the engine may then deliver a finer output_size, resampled from this one,
    // where bilinear lookups into it would miss the tolerance (docs/convolution.md).
    Size sum_size;
    bool size_fixed = false;         // output_size was given (--size or MapRequest::size)
    std::string size_reason;         // why output_size is what it is (report.json)
    // Predicted weighted RMS of lookups between output texels (bilinear: measured on the map by
    // estimate_lookup_error; the lobe lookup: its truncation, below 1e-9), counted in
    // predicted_error; 0 for a fixed size or the mirror.
    double lookup_error = 0;
    // The largest error of a bilinear lookup, relative, estimated the same way (0 when not).
    double lookup_worst = 0;
    // How the map is read between its texels. Bilinear, but for a lobe narrower than half the
    // input's texel spacing without a fixed size (and for one under a whole texel where bilinear
    // grids would miss the tolerance or exceed kMaxOutputHeight): then the map is the input's own
    // texels and a reader applies the lobe (sample_lobe, core/equirect.hpp; report.json "lookup": "lobe"),
    // because between texel centres the exact sum is a step no grid resolves for bilinear
    // lookups (docs/convolution.md, "The lobe lookup").
    MapLookup lookup = MapLookup::Bilinear;
    double cutoff_cos = -1;          // cos of the cut-off angle, -1 = whole sphere
    // The cone's settings for this lobe and tolerance: how a cone plan runs, and
    // how auto's sh with the bright split computes its rows that fail the
    // truncation bound, reading level fallback_level (a cone plan reads input_level).
    ConeSettings cone;
    int fallback_level = 0;
    int bright_texels = 0;           // input texels summed exactly for every output (cone, auto's sh)
    int sh_order = 0;                // bands 0..order-1 (sh)
    bool bright_split = false;       // sh of the map without its bright texels, those added exactly
    int projection_order = 0;        // bright split: bands of the projection the call's split maps share
    double predicted_error = 0;      // predicted weighted relative RMS against exact
    double predicted_cost = 0;       // predicted multiply-adds
    std::string shares_with;         // label of an identical map computed once
    std::string note;                // e.g. why a plan was replaced while it ran

    // Lobe energy dropped outside the cone by the method that computes the map
    // (0 but for the cone).
    double cutoff_energy() const { return method == Method::Cone ? cone.cutoff_energy : 0.0; }
};

struct MapResult {
    MapRequest request;
    MapPlan plan;
    HdrImage image;
    // With Options::fine_tiles: the finer grid's texels where lookups of `image` (the sum grid,
    // plan.output_size) would miss the tolerance; read with sample_bilinear(image, fine, d)
    // (core/fine_tiles.hpp). Empty otherwise.
    FineTiles fine;
    double seconds = 0;              // wall time for this map
    long long refined_texels = 0;    // cone: texels recomputed with a wider cone
    long long patched_texels = 0;    // output texels summed exactly where 4-point resampling would miss
    long long clamped_texels = 0;    // sh: negative channel values clamped to 0
    // The cone of the map's sum grid as it ran (0 / "" when no cone ran on it): the lobe energy its
    // first cone dropped (the plan's cut-off, or less where the Fourier first pass sums whole
    // rows: docs/convolution.md) and its first pass, "fourier" or "direct".
    double cone_cutoff_energy = 0;
    std::string cone_first_pass;
};

// Computes every requested map. Throws InputError on an unusable request
// (negative or non-finite shininess, empty map, bad size, tolerance or SH
// order), from the planner, before any map is computed.
std::vector<MapResult> convolve(const HdrImage& environment, const std::vector<MapRequest>& maps,
                                const Options& options);
// The same, with the map handed over: where no plan reads it whole, the bright split zeroes
// its bright texels in place instead of copying it, and the full-resolution remainder is freed
// once coarser levels are built if no plan reads it (peak memory at 8192x4096).
std::vector<MapResult> convolve(HdrImage&& environment, const std::vector<MapRequest>& maps, const Options& options);

}  // namespace glint::convolution
