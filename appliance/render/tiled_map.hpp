// A reflection map with fine tiles (core/fine_tiles.hpp) as one float texture the shader reads
// through its tiles (shaders/render_lookup.glsl, equirect_tiled), instead of the whole finer grid
// that expand() makes: a 1024x512 sum grid refined 4x is 4096x2048 texels (128 MB of RGBA32F)
// whole, a few MB as tiles. docs/render.md, "Maps with fine tiles".
//
// Layout of the packed image, `width` = the base's width, rows from the top:
//   [0, base rows)            the base (sum grid) itself;
//   [slot_row, atlas_row)     the slot table: tile (tx, ty)'s block number in the red channel of
//                             texel k = ty tiles_x + tx (column k mod width, row slot_row + k div
//                             width), -1 for a tile that is not kept (integers, exact in float);
//   [atlas_row, height)       the blocks, `per_row` side x side blocks across each band of side
//                             rows: block k at column (k mod per_row) side, row atlas_row +
//                             (k div per_row) side.
// One texture keeps the renderer's banded uploads (gl::TextureUpload) as they are for any map.
#pragma once

#include <optional>

#include "appliance/core/fine_tiles.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::render {

struct TiledMapLayout {
    int factor = 0;     // the fine grid's refinement (FineTiles::factor)
    int tile = 0;       // base texels per tile side
    int base_rows = 0;  // the base's height
    int slot_row = 0;   // first row of the slot table
    int atlas_row = 0;  // first row of the blocks
    int per_row = 0;    // blocks across a band
    int height = 0;     // the packed image's rows
};

// The layout for `fine` over a base of width x height texels, or nothing when a block is wider
// than the base (a tiny map) or the packed image would have more rows than the whole finer grid
// and than 2048 (so many tiles that a GPU holding the whole grid might not hold this): expand()
// it instead.
// `fine` must not be empty.
std::optional<TiledMapLayout> tiled_map_layout(int width, int height, const FineTiles& fine);

// The packed image (layout above; `layout` from tiled_map_layout of the same base and tiles).
HdrImage pack_tiled_map(const HdrImage& base, const FineTiles& fine, const TiledMapLayout& layout);

}  // namespace glint::render
