// 8-bit RGB images as PNG files (zlib only; no libpng), written atomically: screenshots of what a
// person would see, and frames of `glint replay`.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

namespace glint::gl {

// Rows top first, 3 bytes a pixel (R, G, B).
struct RgbImage {
    int width = 0, height = 0;
    std::vector<std::uint8_t> pixels;  // width * height * 3
    const std::uint8_t* at(int x, int y) const { return &pixels[(std::size_t(y) * std::size_t(width) + std::size_t(x)) * 3]; }
};

// The PNG file's bytes.
std::vector<std::uint8_t> encode_png(const RgbImage& image);
// Writes it atomically (core/atomic_file.hpp). Throws RuntimeError naming the path.
void save_png(const std::filesystem::path& path, const RgbImage& image);
// Reads a PNG that encode_png wrote (8-bit RGB, not interlaced, any filter): for tests and the
// golden images. Throws InputError naming the path for anything else.
RgbImage load_png(const std::filesystem::path& path);

}  // namespace glint::gl
