// The maps a material shades with (material.hpp, needed_maps): read from a directory that
// `glint convolve` wrote, or convolved here with the CPU engine.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "appliance/convolution/convolution.hpp"
#include "appliance/core/fine_tiles.hpp"
#include "appliance/core/hdr_image.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/tiled_map.hpp"

namespace glint::render {

// One reflection lobe's map: E_s^n or the mirror map, looked up with R.
struct ReflectionMap {
    convolution::MapRequest request;  // its label ("phong_160", "mirror") names it
    HdrImage image;
    std::string from;                 // where it came from, for the log and stats
    // How it is read between texels: bilinear, or through the lobe for a lobe narrower than half
    // the input's texels (the map then holds the input's texels; report.json "lookup").
    MapLookup lookup = MapLookup::Bilinear;
    // Fine tiles of `image` (glint convolve's default for a map that needs a finer grid): the
    // lookup is then sample_bilinear(image, fine, d), `texture` the image and its tiles packed for
    // the shader and `tiles` its layout there (tiled_map.hpp; the shader's uniforms). Empty
    // otherwise (tiles.factor 0); `texture` empty: the renderer uploads image.
    FineTiles fine;
    HdrImage texture;
    TiledMapLayout tiles;
    // No tiles: `image` alone is the map.
    void clear_tiles() {
        fine = FineTiles{};
        texture = HdrImage{};
        tiles = TiledMapLayout{};
    }
    // What a reader that takes one image gets: `image`, or with tiles the whole finer grid.
    HdrImage whole_grid(int threads = 0) const { return fine.empty() ? image : expand(image, fine, threads); }
};

// Gives `map` the tiles `fine` of its image: packed for the shader, or, for a map too narrow for
// a block (tiled_map_layout), its image replaced by the whole finer grid.
void attach_fine_tiles(ReflectionMap& map, FineTiles fine, int threads = 0);

struct ShadingMaps {
    std::optional<HdrImage> irradiance;    // E_d, looked up with N (when any kd > 0)
    std::string irradiance_from;
    std::vector<ReflectionMap> reflections;  // one per distinct specular lobe the materials use

    // The map a specular material looks up, or null when it is not here.
    const ReflectionMap* reflection_for(const Material& material) const;
    // The first reflection map and where it came from (a single material's), or null / "".
    const HdrImage* reflection() const { return reflections.empty() ? nullptr : &reflections.front().image; }
    std::string reflection_from() const { return reflections.empty() ? std::string() : reflections.front().from; }
    // Sets the map of `material`'s lobe (tests and callers that make maps themselves).
    void set_reflection(const Material& material, HdrImage image, std::string from = "given",
                        MapLookup lookup = MapLookup::Bilinear);
};

// Reads the maps of `material` from `dir`: its report.json (written by `glint convolve`) names
// them ("map": "irradiance", "phong_<n>" with "shininess": n, or "mirror"; "file"). Throws
// InputError naming the directory and the map when one is missing, and the file when it cannot
// be read.
ShadingMaps load_maps(const std::filesystem::path& dir, const Material& material);
ShadingMaps load_maps(const std::filesystem::path& dir, const std::vector<Material>& materials);

// Convolves exactly the distinct lobes the material uses (needed_maps) from `environment` with
// the CPU engine: `options` as `glint convolve` takes them (tolerance 0.01 by default).
ShadingMaps convolve_maps(const HdrImage& environment, const Material& material,
                          const convolution::Options& options);
// Several materials (one per part of a model): each distinct lobe once (needed_maps).
ShadingMaps convolve_maps(const HdrImage& environment, const std::vector<Material>& materials,
                          const convolution::Options& options);

}  // namespace glint::render
