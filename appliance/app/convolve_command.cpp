// `glint convolve`: environment map -> irradiance and reflection maps + report.json.
//
// Output files appear all together or not at all: every file is first written
// and fsynced in a staging directory inside DIR, then renamed into place.
#include <chrono>
#include <cmath>
#include <mutex>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>

#include "appliance/app/cli_util.hpp"
#include "appliance/app/gpu_policy.hpp"
#include "appliance/app/interrupt.hpp"
#include "appliance/app/commands.hpp"
#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/gpu/gpu_engine.hpp"
#include "appliance/convolution/planner.hpp"
#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/fine_tiles_io.hpp"
#include "appliance/core/progress.hpp"
#include "appliance/core/strict_number.hpp"

namespace glint::app {
namespace {

namespace fs = std::filesystem;

struct ConvolveArgs {
    std::string input;
    std::string out_dir;
    bool irradiance = false;
    bool mirror = false;
    bool allow_over_tolerance = false;
    std::string shininess;
    std::string method = "auto";
    double tolerance = 0.01;
    std::string size;
    int sh_order = 0;
    int threads = 0;
    EngineChoice engine = EngineChoice::Auto;
    double tile_cap_ms = 50.0;
    bool whole_grids = false;  // --no-fine-tiles
};

nlohmann::json number_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

nlohmann::json size_json(convolution::Size s) { return {s.width, s.height}; }

// The map and tiles files report.json in `dir` lists, or none: only names glint convolve gives
// (the entry's map name + ".exr" or + kFineTilesSuffix, plain names inside `dir`), never `input`
// (a run may read a map an earlier run wrote there).
std::vector<std::string> files_of_earlier_report(const fs::path& dir, const fs::path& input) {
    std::vector<std::string> files;
    std::ifstream in(dir / "report.json");
    if (!in) return files;
    try {
        const nlohmann::json report = nlohmann::json::parse(in);
        for (const auto& entry : report.at("maps")) {
            if (!entry.contains("map") || !entry["map"].is_string()) continue;
            const std::string map = entry["map"].get<std::string>();
            if (entry.contains("file") && entry["file"] == map + ".exr") files.push_back(map + ".exr");
            if (entry.contains("fine_tiles") && entry["fine_tiles"].is_object() &&
                entry["fine_tiles"].value("file", "") == map + kFineTilesSuffix)
                files.push_back(map + kFineTilesSuffix);
        }
    } catch (const std::exception&) {
        return {};  // not ours, or damaged: nothing is removed on its word
    }
    std::erase_if(files, [&](const std::string& f) {
        std::error_code e;
        return f.empty() || fs::path(f).filename().string() != f || f == "." || f == ".." ||
               fs::equivalent(dir / f, input, e);
    });
    return files;
}

// On destruction, removes the directories of `dir`'s path that did not exist at construction
// (`dir` and the parents made with it), innermost first, while they are empty.
class EmptyDirectoryRemover {
public:
    explicit EmptyDirectoryRemover(const fs::path& dir) {
        std::error_code e;
        for (fs::path p = fs::absolute(dir, e); !p.empty() && !fs::exists(p, e); p = p.parent_path()) {
            made_.push_back(p);
            if (p == p.parent_path()) break;
        }
    }
    ~EmptyDirectoryRemover() {
        std::error_code e;
        for (const fs::path& p : made_)
            if (!fs::is_directory(p, e) || !fs::is_empty(p, e) || !fs::remove(p, e)) break;
    }
    EmptyDirectoryRemover(const EmptyDirectoryRemover&) = delete;
    EmptyDirectoryRemover& operator=(const EmptyDirectoryRemover&) = delete;

private:
    std::vector<fs::path> made_;  // innermost first
};

// report.json's "fine_tiles" of a map (null without): the blocks' file, the refinement, the
// tile's side in the map's texels, and the tiles in the blocks' order (fine_tiles_io.hpp reads it).
nlohmann::json fine_tiles_json(const convolution::MapResult& r) {
    if (r.fine.empty()) return nlohmann::json();
    return fine_tiles_to_json(r.fine, r.request.label + kFineTilesSuffix);
}

// A plan that predicts more than the tolerance (mipmap predicts nothing: it is a baseline).
bool over_tolerance(const convolution::MapPlan& p, double tolerance) {
    return std::isfinite(p.predicted_error) && p.predicted_error > tolerance;
}

std::string over_tolerance_cause(const convolution::MapResult& r, const convolution::Options& options) {
    const convolution::MapPlan& p = r.plan;
    if (p.method == convolution::Method::Sh && options.sh_order > 0) return "--sh-order is too low for this lobe";
    if (p.lookup_error > 0.5 * p.predicted_error) return p.size_reason;
    if (p.size_fixed) return "--size " + convolution::to_string(p.output_size) + " with --method " +
                             to_string(options.method);
    return "the method's own error at this lobe";
}

int run_convolve(const ConvolveArgs& args) {
    convolution::Options options;
    options.method = *convolution::parse_method(args.method);  // CLI11 checked the name
    options.tolerance = args.tolerance;  // the planner validates every plan input, once
    if (!args.size.empty()) options.size = parse_size(args.size, "--size");
    options.threads = args.threads;
    options.sh_order = args.sh_order;
    options.fine_tiles = !args.whole_grids;

    std::vector<convolution::MapRequest> maps;
    if (args.irradiance) maps.push_back(convolution::MapRequest::make_irradiance());
    if (!args.shininess.empty()) {
        std::set<double> seen;
        for (const std::string& item : split_list(args.shininess, "--shininess")) {
            const double n = parse_double(item, "--shininess");
            if (n < 0) throw InputError("--shininess: '" + item + "' is negative");
            if (!seen.insert(n).second) throw InputError("--shininess: '" + item + "' is given twice");
            maps.push_back(convolution::MapRequest::make_phong(n, item));
        }
    }

    if (args.mirror) maps.push_back(convolution::MapRequest::make_mirror());

    const fs::path out_dir(args.out_dir);
    // A run that writes nothing (refused, or failed) leaves no directory it made behind.
    const EmptyDirectoryRemover made_out_dir(out_dir);
    ensure_writable_directory(out_dir);
    const auto load_start = std::chrono::steady_clock::now();
    LoadedExr loaded = load_exr(args.input);
    const convolution::Size input_size{loaded.image.width(), loaded.image.height()};
    const std::size_t input_texels = loaded.image.texel_count();
    const double load_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - load_start).count();
    std::error_code size_error;
    const double file_mb = double(fs::file_size(args.input, size_error)) / 1e6;
    convolution::validate_plan_inputs(input_size, maps, options);
    warn_about_environment(args.input, loaded);

    // The engine reports rows done and the total; draw from that.
    options.progress = progress_callback("convolving");
    GpuChoice gpu(args.engine, "convolution");
    std::unique_ptr<convolution::gpu::UnlimitedGate> gate;
    std::unique_ptr<convolution::gpu::GpuEngine> gpu_engine;
    if (gpu.context()) {
        try {
            gate = std::make_unique<convolution::gpu::UnlimitedGate>(args.tile_cap_ms);
            gpu_engine = std::make_unique<convolution::gpu::GpuEngine>(*gpu.context(), *gate, args.tile_cap_ms);
        } catch (const RuntimeError& e) {
            gpu.give_up(e.what());
        }
    }
    options.executor = gpu_engine.get();
    const auto start = std::chrono::steady_clock::now();
    const std::vector<convolution::MapResult> results = convolution::convolve(std::move(loaded.image), maps, options);
    const double total_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    options.progress = nullptr;  // the last copy of the callback: its bar finishes here, before the report

    nlohmann::json report;
    report["input"] = {{"path", args.input},
                       {"size", {input_size.width, input_size.height}},
                       {"luminance_only", loaded.luminance_only},
                       {"sanitised", {{"nan", loaded.sanitised.nan},
                                      {"pos_inf", loaded.sanitised.pos_inf},
                                      {"neg_inf", loaded.sanitised.neg_inf},
                                      {"negative", loaded.sanitised.negative}}}};
    report["tolerance"] = options.tolerance;
    report["method"] = args.method;
    report["threads"] = args.threads;
    report["engine"] = gpu_engine ? "gpu" : "cpu";
    if (gpu_engine) {
        report["gpu"] = {{"renderer", gpu.context()->caps().renderer},
                         {"version", gpu.context()->caps().version},
                         {"tiles", gpu_engine->stats().tiles},
                         {"gpu_ms", gpu_engine->stats().gpu_ms},
                         {"largest_tile_ms", gpu_engine->stats().largest_ms},
                         {"tile_cap_ms", args.tile_cap_ms}};
    }
    report["wall_seconds"] = total_seconds;  // convolve() alone: planning and every map
    report["load_seconds"] = load_seconds;
    report["load_mb_per_s"] = size_error || load_seconds <= 0 ? nlohmann::json() : nlohmann::json(file_mb / load_seconds);
    report["load_megatexels_per_s"] =
        load_seconds > 0 ? nlohmann::json(double(input_texels) / 1e6 / load_seconds) : nlohmann::json();
    report["maps"] = nlohmann::json::array();
    for (const auto& r : results) {
        const auto& p = r.plan;
        report["maps"].push_back({
            {"map", r.request.label},
            {"file", r.request.label + ".exr"},
            {"shininess", r.request.shininess},
            {"method", convolution::to_string(p.method)},
            {"input_level", p.input_level},
            {"input_size", size_json(p.input_size)},
            {"output_size", size_json(p.output_size)},
            {"sum_size", size_json(p.sum_size)},
            {"size_reason", p.size_reason},
            {"lookup_error", p.lookup_error},
            {"lookup_worst", p.lookup_worst},
            {"lookup", to_string(p.lookup)},
            {"cutoff_energy", p.cutoff_energy()},
            {"cutoff_cos", p.cutoff_cos},
            {"bright_texels", p.bright_texels},
            {"sh_order", p.sh_order},
            {"bright_split", p.bright_split},
            {"note", p.note.empty() ? nlohmann::json() : nlohmann::json(p.note)},
            {"predicted_error", number_or_null(p.predicted_error)},
            {"over_tolerance", over_tolerance(p, options.tolerance)},
            {"predicted_cost", p.predicted_cost},
            {"wall_seconds", r.seconds},
            {"shares_with", p.shares_with.empty() ? nlohmann::json() : nlohmann::json(p.shares_with)},
            {"refined_texels", r.refined_texels},
            {"cone_cutoff_energy", r.cone_first_pass.empty() ? nlohmann::json() : nlohmann::json(r.cone_cutoff_energy)},
            {"cone_first_pass", r.cone_first_pass.empty() ? nlohmann::json() : nlohmann::json(r.cone_first_pass)},
            {"patched_texels", r.patched_texels},
            {"clamped_values", r.clamped_texels},
            {"fine_tiles", fine_tiles_json(r)},
        });
    }

    // A map predicted to miss the tolerance is not delivered as if it met it: name each one and
    // write nothing, unless asked to (then report.json marks them).
    std::vector<const convolution::MapResult*> over;
    for (const auto& r : results)
        if (over_tolerance(r.plan, options.tolerance)) over.push_back(&r);
    for (const auto* r : over)
        std::fprintf(stderr, "glint: %s: %s: predicted error %.3g exceeds --tolerance %.3g (%s)\n",
                     args.allow_over_tolerance ? "warning" : "error", r->request.label.c_str(),
                     r->plan.predicted_error, options.tolerance, over_tolerance_cause(*r, options).c_str());
    // The thesis' MIP-mapping baseline has no error model (predicted_error null): its maps are
    // not checked against the tolerance, and may be far off (275 % RMS on a small sun, 2026-12-06).
    for (const auto& r : results)
        if (!std::isfinite(r.plan.predicted_error))
            std::fprintf(stderr,
                         "glint: warning: %s: --method %s has no error model: not checked against --tolerance "
                         "(report.json predicted_error null; a baseline for comparison, not for use)\n",
                         r.request.label.c_str(), convolution::to_string(r.plan.method).c_str());
    if (!over.empty() && !args.allow_over_tolerance) {
        std::fprintf(stderr,
                     "glint: wrote nothing to %s: %zu map(s) over the tolerance (give a larger --tolerance, "
                     "or --allow-over-tolerance to write them marked in report.json)\n",
                     out_dir.c_str(), over.size());
        return 1;
    }

    // Stage every file, then move them into place together (interrupt.hpp: a signal removes the
    // staging directory and leaves DIR as it was).
    StagingDirectory staging(out_dir);
    std::vector<std::string> names;
    for (const auto& r : results) {
        names.push_back(r.request.label + ".exr");
        if (!r.fine.empty()) names.push_back(r.request.label + kFineTilesSuffix);
    }
    names.push_back("report.json");
    staging.write([&] {
        // Uncompressed: the maps' float noise does not compress (docs/convolution.md).
        for (const auto& r : results) {
            save_exr(staging.file(r.request.label + ".exr"), r.image, ExrCompression::None);
            if (!r.fine.empty())
                save_exr(staging.file(r.request.label + kFineTilesSuffix), r.fine.blocks, ExrCompression::None);
        }
        write_text_atomically(staging.file("report.json"), report.dump(2) + "\n");
    });
    const std::vector<std::string> earlier = files_of_earlier_report(out_dir, args.input);
    staging.commit(names);
    // Files an earlier run wrote here (its report.json listed them) that this run did not write
    // again, e.g. a tiles file beside a map now delivered whole, or a map not asked for this
    // time: report.json no longer names them, and left beside the new maps they would mislead.
    const std::set<std::string> written(names.begin(), names.end());
    for (const std::string& name : earlier) {
        std::error_code ignored;
        if (!written.count(name)) fs::remove(out_dir / name, ignored);
    }

    for (const auto& r : results) {
        const auto& p = r.plan;
        std::printf("%-16s %-6s level %d (%dx%d) -> %dx%d  predicted %.2g  %.3f s%s\n",
                    r.request.label.c_str(), convolution::to_string(p.method).c_str(), p.input_level,
                    p.input_size.width, p.input_size.height, p.output_size.width, p.output_size.height,
                    std::isfinite(p.predicted_error) ? p.predicted_error : -1.0, r.seconds,
                    p.shares_with.empty() ? "" : (" (same map as " + p.shares_with + ")").c_str());
    }
    for (const auto& r : results)
        if (!r.fine.empty())
            std::printf("%-16s fine tiles: %d tiles of %dx%d texels, %dx finer (%s)\n", r.request.label.c_str(),
                        r.fine.count(), r.fine.tile, r.fine.tile, r.fine.factor,
                        (r.request.label + kFineTilesSuffix).c_str());
    std::printf("wrote %zu maps and report.json to %s in %.3f s\n", results.size(), out_dir.c_str(),
                total_seconds);
    return 0;
}

}  // namespace

Command add_convolve_command(CLI::App& app) {
    auto args = std::make_shared<ConvolveArgs>();
    CLI::App* cmd = app.add_subcommand("convolve", std::string(command_summary("convolve").summary));
    cmd->add_option("input", args->input, "Equirectangular HDR environment map (OpenEXR)")->required();
    cmd->add_option("--out", args->out_dir, "Output directory (created if missing)")->required();
    cmd->add_flag("--irradiance", args->irradiance, "Compute the irradiance map (irradiance.exr)");
    cmd->add_option("--shininess", args->shininess,
                    "Comma-separated Phong exponents 0 <= n <= 1e7, e.g. 20,60,160 (phong_<n>.exr)");
    cmd->add_flag("--mirror", args->mirror,
                  "Compute the mirror map (n = infinity: the environment filtered to the output's texels; mirror.exr)");
    cmd->add_flag("--allow-over-tolerance", args->allow_over_tolerance,
                  "Write maps predicted to miss --tolerance too (marked over_tolerance in report.json); "
                  "without it such a run writes nothing and exits 1");
    cmd->add_option("--method", args->method, "auto, exact, cone, sh or mipmap")
        ->check(CLI::IsMember({"auto", "exact", "cone", "sh", "mipmap"}))
        ->capture_default_str();
    cmd->add_option("--tolerance", args->tolerance,
                    "Target weighted relative RMS error against exact, in (0, 1): 0.01 = 1 %")
        ->capture_default_str();
    cmd->add_option("--size", args->size, "Fix every output map's size, WxH (default: the lobe's and the map's own, see report.json size_reason)")
        ->check(size_validator());
    cmd->add_option("--sh-order", args->sh_order, "SH bands for --method sh, 1..1024; 0 = chosen from n and tolerance")
        ->capture_default_str();
    cmd->add_option("--threads", args->threads, "Worker threads; 0 = all cores")
        ->check(non_negative_number())
        ->capture_default_str();
    add_engine_option(*cmd, args->engine, "the same plans with the sums as GLES3 shaders");
    cmd->add_option("--tile-cap-ms", args->tile_cap_ms, "GPU engine: longest single draw, ms (> 0)")
        ->check(positive_number())
        ->capture_default_str();
    cmd->add_flag("--no-fine-tiles", args->whole_grids,
                  "Deliver a map that needs a finer grid than it is summed on as that whole grid (<map>.exr); "
                  "by default it keeps its sum grid and gets the finer grid only in tiles where lookups would "
                  "miss (<map>.tiles.exr, report.json \"fine_tiles\")");
    return {cmd, [args] { return run_convolve(*args); }};
}

}  // namespace glint::app
