// `glint compare A.exr REFERENCE.exr`: the error metrics of docs/conventions.md,
// so test engineers can compare any two maps the way the tests and benchmarks do.
//
// A map is judged as a renderer reads it. `glint convolve` marks a map read through its lobe
// ("lookup": "lobe" in report.json: its texels are the input's radiance, docs/convolution.md "The
// lobe lookup"); read bilinearly such a map is off by its whole lobe. So the map's report.json,
// when one lies beside it and lists the file, says how to read it (--lookup auto), and --lookup
// names it otherwise. An exported scene's maps/maps.json serves the same way.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <optional>

#include <nlohmann/json.hpp>

#include "appliance/app/cli_util.hpp"
#include "appliance/app/commands.hpp"
#include "appliance/core/error_metrics.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/fine_tiles_io.hpp"

namespace glint::app {

namespace {

namespace fs = std::filesystem;

struct LookupChoice {
    MapLookup lookup = MapLookup::Bilinear;
    double shininess = 0;
    std::string from;  // what said so
    nlohmann::json fine_tiles;  // the entry's "fine_tiles" (null: none)
};

// A listing's entry for `map` -> its lookup; `where` names the listing in errors.
LookupChoice lookup_of_entry(const nlohmann::json& entry, const fs::path& map, const std::string& where) {
    LookupChoice c;
    c.from = where;
    if (entry.contains("fine_tiles")) c.fine_tiles = entry["fine_tiles"];
    const nlohmann::json how = entry.contains("lookup") ? entry["lookup"] : nlohmann::json("bilinear");
    const std::optional<MapLookup> known =
        how.is_string() ? map_lookup_from_string(how.get<std::string>()) : std::nullopt;
    if (!known)
        throw InputError(where + ": " + map.filename().string() + " has lookup " + how.dump() +
                         " (glint compare reads \"bilinear\" and \"lobe\")");
    if (*known == MapLookup::Bilinear) return c;
    if (!entry.contains("shininess") || !entry["shininess"].is_number() || !(entry["shininess"].get<double>() > 0))
        throw InputError(where + ": " + map.filename().string() +
                         " has lookup \"lobe\" but no positive shininess (pass --lookup lobe --shininess N)");
    c.lookup = MapLookup::Lobe;
    c.shininess = entry["shininess"].get<double>();
    return c;
}

nlohmann::json read_listing(const fs::path& path) {
    std::ifstream in(path);
    try {
        return nlohmann::json::parse(in);
    } catch (const std::exception& e) {
        throw InputError(path.string() + ": not JSON: " + e.what() + " (or pass --lookup)");
    }
}

// The lookup the listing beside `map` gives it, if one lists the file: glint convolve's
// report.json ("maps": [{"file", "lookup", "shininess"}, ...]) or an exported scene's
// maps/maps.json ({"FILE": {"lookup", "shininess"}, ...}). Nothing otherwise.
std::optional<LookupChoice> lookup_from_listing(const fs::path& map) {
    const std::string name = map.filename().string();
    const fs::path report_path = map.parent_path() / "report.json";
    if (fs::exists(report_path)) {
        const nlohmann::json report = read_listing(report_path);
        if (report.is_object() && report.contains("maps") && report["maps"].is_array())
            for (const auto& entry : report["maps"])
                if (entry.is_object() && entry.contains("file") && entry["file"] == name)
                    return lookup_of_entry(entry, map, report_path.string());
    }
    const fs::path index_path = map.parent_path() / "maps.json";
    if (fs::exists(index_path)) {
        const nlohmann::json index = read_listing(index_path);
        if (index.is_object() && index.contains(name) && index[name].is_object())
            return lookup_of_entry(index[name], map, index_path.string());
    }
    return std::nullopt;
}

}  // namespace

Command add_compare_command(CLI::App& app) {
    struct Args {
        std::string approx, reference, lookup = "auto";
        double shininess = 0;
    };
    auto args = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand("compare", std::string(command_summary("compare").summary));
    cmd->add_option("map", args->approx, "Map to judge (OpenEXR)")->required();
    cmd->add_option("reference", args->reference, "Reference map (OpenEXR)")->required();
    cmd->add_option("--lookup", args->lookup,
                    "How the map is read between texel centres: auto (the report.json or maps.json beside the map, "
                    "when it lists the file, else bilinear), bilinear, or lobe (needs --shininess)")
        ->check(CLI::IsMember({"auto", "bilinear", "lobe"}))
        ->capture_default_str();
    CLI::Option* shininess =
        cmd->add_option("--shininess", args->shininess, "The lobe's Phong exponent for --lookup lobe (> 0)")
            ->check(positive_number());
    return {cmd, [args, shininess] {
                // The flags first: a conflict is the user's, whatever the files say.
                if (shininess->count() > 0 && args->lookup != "lobe")
                    throw InputError("--shininess is for --lookup lobe only");
                if (args->lookup == "lobe" && shininess->count() == 0)
                    throw InputError("--lookup lobe needs --shininess N > 0 (the map's Phong exponent)");
                LookupChoice choice;
                // The listing beside the map, if one lists it: its lookup for --lookup auto, and
                // its fine tiles whatever --lookup says (they are part of the map).
                const std::optional<LookupChoice> listed = lookup_from_listing(args->approx);
                if (args->lookup == "lobe") {
                    choice = {MapLookup::Lobe, args->shininess, "--lookup", nlohmann::json()};
                } else if (args->lookup == "bilinear") {
                    choice.from = "--lookup";
                } else if (listed) {
                    choice = *listed;
                } else {
                    choice.from = "default: no report.json or maps.json beside the map lists it";
                }
                HdrImage a = load_exr(args->approx).image;
                // A map with fine tiles (glint convolve's default) is read through them: as
                // its whole finer grid, whose texels are the tiles' or the map's own lookups.
                const FineTiles fine =
                    listed ? load_fine_tiles(listed->fine_tiles, fs::path(args->approx).parent_path(), a,
                                             listed->from + ": " + fs::path(args->approx).filename().string())
                           : FineTiles{};
                if (!fine.empty()) {
                    a = expand(a, fine);
                    choice.from += ", with its fine tiles";
                }
                const HdrImage b = load_exr(args->reference).image;
                const MapError e = compare_maps(a, b, choice.lookup, choice.shininess);
                std::printf("weighted_rel_rms %.6e\nworst_texel %.6e\nmean_abs_percent %.6f\nmax_abs_percent %.6f\n",
                            e.weighted_relative_rms, e.worst_texel, e.mean_abs_percent, e.max_abs_percent);
                std::printf("lookup %s (%s)\n", to_string(choice.lookup), choice.from.c_str());
                return 0;
            }};
}

}  // namespace glint::app
