// OpenEXR load and save in the conventions of docs/conventions.md.
#pragma once

#include <filesystem>

#include "appliance/core/hdr_image.hpp"

namespace glint {

struct LoadedExr {
    HdrImage image;
    SanitiseCounts sanitised;  // what the loader changed (NaN, Inf, negatives)
    bool luminance_only = false;  // the file had a Y channel and no R, G, B
};

// Loads R, G, B (HALF, FLOAT or UINT; any channel order) or, failing that, Y
// copied to all three. Scanline or tiled files; the data window is the image.
// Sanitises the texels and reports the counts. Throws InputError naming the
// file on a missing, corrupt, truncated or channel-less file.
LoadedExr load_exr(const std::filesystem::path& path);

enum class ExrCompression { Zip, None };

// Saves R, G, B as FLOAT, atomically (temp, fsync, rename). ZIP (zlib level 1) by default;
// None for maps whose float noise does not compress: `glint convolve`'s outputs were 7 %
// smaller with ZIP and took 4.6x longer to write (docs/convolution.md).
void save_exr(const std::filesystem::path& path, const HdrImage& image,
              ExrCompression compression = ExrCompression::Zip);

}  // namespace glint
