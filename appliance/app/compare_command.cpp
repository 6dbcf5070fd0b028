// `glint compare A.exr REFERENCE.exr`: the error metrics of docs/conventions.md,
// so test engineers can compare any two maps the way the tests and benchmarks do.
//
// A map is judged as a renderer reads it. `glint convolve` marks a map read through its lobe
// ("lookup": "lobe" in report.json: its texels are the input's radiance, docs/convolution.md "The
// lobe lookup"); read bilinearly such a map is off by its whole lobe. So the map's report.json,
// when one lies beside it and lists the file, says how to read it (--lookup auto), and --lookup
// names it otherwise.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>

#include <nlohmann/json.hpp>

#include "appliance/app/commands.hpp"
#include "appliance/core/error_metrics.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"

namespace glint::app {

namespace {

namespace fs = std::filesystem;

struct LookupChoice {
    MapLookup lookup = MapLookup::Bilinear;
    double shininess = 0;
    std::string from;  // what said so
};

// The lookup report.json beside `map` gives it, if it lists the file; nothing otherwise.
std::optional<LookupChoice> lookup_from_report(const fs::path& map) {
    const fs::path report_path = map.parent_path() / "report.json";
    std::ifstream in(report_path);
    if (!in) return std::nullopt;
    nlohmann::json report;
    try {
        report = nlohmann::json::parse(in);
    } catch (const std::exception& e) {
        throw InputError(report_path.string() + ": not JSON: " + e.what() + " (or pass --lookup)");
    }
    if (!report.contains("maps") || !report["maps"].is_array()) return std::nullopt;
    for (const auto& entry : report["maps"]) {
        if (!entry.is_object() || entry.value("file", std::string()) != map.filename().string()) continue;
        LookupChoice c;
        c.from = report_path.string();
        const std::string how = entry.value("lookup", std::string("bilinear"));
        if (how == "bilinear") return c;
        if (how != "lobe")
            throw InputError(report_path.string() + ": " + map.filename().string() + " has lookup \"" + how +
                             "\" (glint compare reads \"bilinear\" and \"lobe\")");
        if (!entry.contains("shininess") || !entry["shininess"].is_number())
            throw InputError(report_path.string() + ": " + map.filename().string() +
                             " has lookup \"lobe\" but no numeric shininess");
        c.lookup = MapLookup::Lobe;
        c.shininess = entry["shininess"].get<double>();
        return c;
    }
    return std::nullopt;
}

}  // namespace

Command add_compare_command(CLI::App& app) {
    struct Args {
        std::string approx, reference, lookup = "auto";
        double shininess = -1;
    };
    auto args = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand("compare", std::string(command_summary("compare").summary));
    cmd->add_option("map", args->approx, "Map to judge (OpenEXR)")->required();
    cmd->add_option("reference", args->reference, "Reference map (OpenEXR)")->required();
    cmd->add_option("--lookup", args->lookup,
                    "How the map is read between texel centres: auto (report.json beside the map, when it lists the "
                    "file, else bilinear), bilinear, or lobe (needs --shininess)")
        ->check(CLI::IsMember({"auto", "bilinear", "lobe"}))
        ->capture_default_str();
    cmd->add_option("--shininess", args->shininess, "The lobe's Phong exponent for --lookup lobe (> 0)");
    return {cmd, [args] {
                LookupChoice choice;
                if (args->lookup == "lobe") {
                    if (!(args->shininess > 0))
                        throw InputError("--lookup lobe needs --shininess N > 0 (the map's Phong exponent)");
                    choice = {MapLookup::Lobe, args->shininess, "--lookup"};
                } else if (args->lookup == "bilinear") {
                    choice.from = "--lookup";
                } else if (const auto found = lookup_from_report(args->approx)) {
                    choice = *found;
                } else {
                    choice.from = "default: no report.json beside the map lists it";
                }
                if (args->shininess > 0 && args->lookup != "lobe")
                    throw InputError("--shininess is for --lookup lobe only");
                const HdrImage a = load_exr(args->approx).image;
                const HdrImage b = load_exr(args->reference).image;
                const MapError e = compare_maps(a, b, choice.lookup, choice.shininess);
                std::printf("weighted_rel_rms %.6e\nworst_texel %.6e\nmean_abs_percent %.6f\nmax_abs_percent %.6f\n",
                            e.weighted_relative_rms, e.worst_texel, e.mean_abs_percent, e.max_abs_percent);
                std::printf("lookup %s (%s)\n", to_string(choice.lookup), choice.from.c_str());
                return 0;
            }};
}

}  // namespace glint::app
