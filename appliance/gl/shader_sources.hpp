// The GLSL ES sources of shaders/, embedded into the binary at build time
// (cmake/EmbedShaders.cmake), so the kiosk never reads shader files at run time.
#pragma once

#include <string_view>
#include <vector>

namespace glint::gl {

struct ShaderSource {
    std::string_view name;  // file name in shaders/, e.g. "convolve_exact.frag"
    std::string_view text;
};

// Every shader file, sorted by name.
const std::vector<ShaderSource>& shader_sources();

}  // namespace glint::gl
