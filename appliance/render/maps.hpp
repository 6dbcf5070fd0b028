// The maps a material shades with (material.hpp, needed_maps): read from a directory that
// `glint convolve` wrote, or convolved here with the CPU engine.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "appliance/convolution/convolution.hpp"
#include "appliance/core/hdr_image.hpp"
#include "appliance/render/material.hpp"

namespace glint::render {

struct ShadingMaps {
    std::optional<HdrImage> irradiance;  // E_d, looked up with N (when kd > 0)
    std::optional<HdrImage> reflection;  // E_s^n or the mirror map, looked up with R (when ks > 0)
    std::string irradiance_from, reflection_from;  // where each came from, for the log and stats
};

// Reads the maps of `material` from `dir`: its report.json (written by `glint convolve`) names
// them ("map": "irradiance", "phong_<n>" with "shininess": n, or "mirror"; "file"). Throws
// InputError naming the directory and the map when one is missing, and the file when it cannot
// be read.
ShadingMaps load_maps(const std::filesystem::path& dir, const Material& material);

// Convolves exactly the distinct lobes the material uses (needed_maps) from `environment` with
// the CPU engine: `options` as `glint convolve` takes them (tolerance 0.01 by default).
ShadingMaps convolve_maps(const HdrImage& environment, const Material& material,
                          const convolution::Options& options);

}  // namespace glint::render
