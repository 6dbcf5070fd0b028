#include "appliance/render/maps.hpp"

#include <cmath>
#include <fstream>
#include <string>
#include <nlohmann/json.hpp>

#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/fine_tiles_io.hpp"
#include "appliance/render/tiled_map.hpp"

namespace glint::render {
namespace {

namespace fs = std::filesystem;

std::string describe_plan(const convolution::MapResult& r) {
    return "convolved (" + convolution::to_string(r.plan.method) + ", " + convolution::to_string(r.plan.output_size) +
           ")";
}

}  // namespace

const ReflectionMap* ShadingMaps::reflection_for(const Material& material) const {
    if (!material.specular()) return nullptr;
    const std::string label = reflection_request(material).label;
    for (const ReflectionMap& r : reflections)
        if (r.request.label == label) return &r;
    return nullptr;
}

void ShadingMaps::set_reflection(const Material& material, HdrImage image, std::string from, MapLookup lookup) {
    const convolution::MapRequest request = reflection_request(material);
    for (ReflectionMap& r : reflections)
        if (r.request.label == request.label) {
            r.image = std::move(image);
            r.from = std::move(from);
            r.lookup = lookup;
            r.clear_tiles();
            return;
        }
    reflections.push_back({request, std::move(image), std::move(from), lookup, {}, {}, {}});
}

void attach_fine_tiles(ReflectionMap& map, FineTiles fine, int threads) {
    map.clear_tiles();
    if (fine.empty()) return;
    const std::string tiles = std::to_string(fine.count()) + " of " + std::to_string(fine.slot.size()) + " tiles " +
                              std::to_string(fine.factor) + "x finer";
    if (const auto layout = tiled_map_layout(map.image.width(), map.image.height(), fine)) {
        map.texture = pack_tiled_map(map.image, fine, *layout);
        map.tiles = *layout;
        map.fine = std::move(fine);
        map.from += " (" + tiles + ", read through them)";
    } else {
        map.image = expand(map.image, fine, threads);
        map.from += " (" + tiles + ", expanded to " + std::to_string(map.image.width()) + "x" +
                    std::to_string(map.image.height()) + ")";
    }
}

ShadingMaps load_maps(const fs::path& dir, const Material& material) {
    return load_maps(dir, std::vector<Material>{material});
}

ShadingMaps load_maps(const fs::path& dir, const std::vector<Material>& materials) {
    const fs::path report_path = dir / "report.json";
    std::ifstream in(report_path);
    if (!in) throw InputError("--maps " + dir.string() + ": no report.json (write the maps with glint convolve)");
    nlohmann::json report;
    try {
        report = nlohmann::json::parse(in);
    } catch (const std::exception& e) {
        throw InputError(report_path.string() + ": not JSON: " + e.what());
    }
    if (!report.contains("maps") || !report["maps"].is_array())
        throw InputError(report_path.string() + ": has no \"maps\" list");

    ShadingMaps out;
    for (const convolution::MapRequest& want : needed_maps(materials)) {
        std::string file;
        std::string listed;
        MapLookup lookup = MapLookup::Bilinear;
        nlohmann::json fine_tiles;
        for (const auto& entry : report["maps"]) {
            const std::string label = entry.value("map", "");
            listed += (listed.empty() ? "" : ", ") + label;
            bool match = false;
            if (want.irradiance) match = label == "irradiance";
            else if (want.mirror) match = label == "mirror";
            else match = label.rfind("phong_", 0) == 0 && entry.contains("shininess") &&
                         entry["shininess"].is_number() && entry["shininess"].get<double>() == want.shininess;
            if (match && file.empty()) {
                file = entry.value("file", label + ".exr");
                if (entry.contains("fine_tiles")) fine_tiles = entry["fine_tiles"];
                const std::string how = entry.value("lookup", "bilinear");
                if (const auto known = map_lookup_from_string(how)) lookup = *known;
                else
                    throw InputError(report_path.string() + ": map " + label + " has lookup \"" + how +
                                     "\" (this renderer reads \"bilinear\" and \"lobe\")");
            }
        }
        if (file.empty())
            throw InputError("--maps " + dir.string() + ": report.json lists no " + want.label + " map (it lists: " +
                             (listed.empty() ? "none" : listed) + ")");
        const fs::path path = dir / file;
        HdrImage image = load_exr(path).image;
        // Fine tiles (glint convolve's default for a map that needs a finer grid): a reflection
        // map keeps them, read through them by the shader (tiled_map.hpp); an irradiance map (its
        // lobe is too wide to need them) would be taken as its whole finer grid.
        FineTiles fine = load_fine_tiles(fine_tiles, dir, image, report_path.string() + ": " + file);
        if (want.irradiance) {
            out.irradiance = fine.empty() ? std::move(image) : expand(image, fine);
            out.irradiance_from = path.string();
        } else {
            out.reflections.push_back({want, std::move(image), path.string(), lookup, {}, {}, {}});
            attach_fine_tiles(out.reflections.back(), std::move(fine));
        }
    }
    return out;
}

ShadingMaps convolve_maps(const HdrImage& environment, const Material& material,
                          const convolution::Options& options) {
    return convolve_maps(environment, std::vector<Material>{material}, options);
}

ShadingMaps convolve_maps(const HdrImage& environment, const std::vector<Material>& materials,
                          const convolution::Options& options) {
    // Exactly the distinct lobes the materials use, in one call (the engine shares its set-up).
    const auto requests = needed_maps(materials);
    std::vector<convolution::MapResult> results = convolution::convolve(environment, requests, options);
    ShadingMaps out;
    for (auto& r : results) {
        if (r.request.irradiance) {  // tiles kept as load_maps keeps them
            out.irradiance_from = describe_plan(r);
            out.irradiance = r.fine.empty() ? std::move(r.image) : expand(r.image, r.fine, options.threads);
        } else {
            out.reflections.push_back({r.request, std::move(r.image), describe_plan(r), r.plan.lookup, {}, {}, {}});
            attach_fine_tiles(out.reflections.back(), std::move(r.fine), options.threads);
        }
    }
    return out;
}

}  // namespace glint::render
