// Packing a map's fine tiles into one texture (tiled_map.hpp).
#include "appliance/render/tiled_map.hpp"

#include <algorithm>

#include "appliance/core/errors.hpp"

namespace glint::render {

std::optional<TiledMapLayout> tiled_map_layout(int width, int height, const FineTiles& fine) {
    if (fine.empty()) throw RuntimeError("internal: a tiled map's layout without tiles");
    const int side = fine.side();
    if (width < side) return std::nullopt;
    TiledMapLayout l;
    l.factor = fine.factor;
    l.tile = fine.tile;
    l.base_rows = height;
    l.slot_row = height;
    const long long slots = (long long)fine.tiles_x * fine.tiles_y;
    l.atlas_row = l.slot_row + int((slots + width - 1) / width);
    l.per_row = width / side;
    const int bands = (fine.count() + l.per_row - 1) / l.per_row;
    l.height = l.atlas_row + bands * side;
    // Never taller than the whole finer grid (a GPU whose texture limit holds that must hold
    // this; with many tiles kept the bands of blocks can outgrow it), or than 2048 rows, what
    // every OpenGL ES 3.0 GPU holds.
    constexpr long long kRowsEveryGpuHolds = 2048;
    if ((long long)l.height > std::max((long long)height * fine.factor, kRowsEveryGpuHolds)) return std::nullopt;
    return l;
}

HdrImage pack_tiled_map(const HdrImage& base, const FineTiles& fine, const TiledMapLayout& l) {
    const int width = base.width();
    HdrImage out(width, l.height);  // zeros: the unused texels of the last rows
    std::copy_n(base.row(0), base.texel_count() * 3, out.row(0));
    for (std::size_t k = 0; k < fine.slot.size(); ++k)
        out.row(l.slot_row)[k * 3] = float(fine.slot[k]);  // rows are consecutive
    const int side = fine.side();
    for (int k = 0; k < fine.count(); ++k) {
        const int x = (k % l.per_row) * side, y = l.atlas_row + (k / l.per_row) * side;
        for (int v = 0; v < side; ++v)
            std::copy_n(fine.blocks.row(k * side + v), 3 * side, out.row(y + v) + 3 * x);
    }
    return out;
}

}  // namespace glint::render
