// Environments and names shared by the renderer's GPU tests.
#pragma once

#include <cctype>
#include <filesystem>
#include <string>

#include "appliance/core/exr_io.hpp"

namespace glint::test {

// The mean over f x f blocks: keeps every light's power while making a map small enough for
// `exact`.
inline HdrImage block_mean(const HdrImage& full, int f) {
    HdrImage out(full.width() / f, full.height() / f);
    for (int j = 0; j < out.height(); ++j)
        for (int i = 0; i < out.width(); ++i) {
            double s[3] = {0, 0, 0};
            for (int y = 0; y < f; ++y)
                for (int x = 0; x < f; ++x)
                    for (int c = 0; c < 3; ++c) s[c] += full.row(j * f + y)[3 * (i * f + x) + c];
            out.set(i, j, {float(s[0] / (f * f)), float(s[1] / (f * f)), float(s[2] / (f * f))});
        }
    return out;
}

// A Blender world averaged over 4x4 blocks (1024x512 -> 256x128): small enough for `exact` in a
// test.
inline HdrImage small_blender_world(const std::string& name) {
    return block_mean(load_exr(std::filesystem::path(GLINT_BLENDER_WORLDS) / (name + ".exr")).image, 4);
}

// A gtest parameter name from free text ("glossy:160" -> "glossy_160").
inline std::string test_name(std::string text) {
    for (char& c : text)
        if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
    return text;
}

}  // namespace glint::test
