// A map delivered as a base grid plus blocks of a finer grid only where bilinear lookups of the
// base would miss the tolerance (docs/convolution.md, "Fine tiles"): the few bright texels'
// sharp lobes get the finer texels they need, the rest of the sphere keeps the base's.
//
// Geometry. The fine grid is `factor` times the base's in both directions. The base is cut into
// tiles of `tile` x `tile` texels; a kept tile holds the fine texels of the fine cells whose
// top-left corner lies in it, i.e. the fine columns [tx T, tx T + T] and rows [ty T, ty T + T]
// (T = tile * factor; the last column wraps round the seam to column 0, a row past the last is
// the last, as the bilinear lookup clamps). A lookup whose fine cell lies in a kept tile reads
// those four fine texels (exactly what a bilinear lookup of the whole fine grid would read); any
// other reads the base bilinearly.
#pragma once

#include <vector>

#include <glm/vec3.hpp>

#include "appliance/core/hdr_image.hpp"

namespace glint {

struct FineTiles {
    // Bounds a reader holds a listing to (glint convolve makes factors of 2 to 8 and finer
    // grids of at most 2048 rows): a whole finer grid of 8192 rows is 1.6 GB of floats.
    static constexpr int kMaxFactor = 16;
    static constexpr long long kMaxFineHeight = 8192;

    int factor = 1;              // fine grid = factor x the base's, in both directions
    int tile = 0;                // base texels per tile side (0: no tiles)
    int tiles_x = 0, tiles_y = 0;  // base width / tile, base height / tile
    std::vector<int> slot;       // per tile, row-major: its block in `blocks`, or -1
    // Block k holds rows [k side, (k + 1) side) of a side-wide image (side = tile factor + 1):
    // fine texel (tx T + u, ty T + v) at (u, k side + v).
    HdrImage blocks;

    bool empty() const { return tile == 0 || blocks.empty(); }
    int side() const { return tile * factor + 1; }
    int count() const { return blocks.empty() ? 0 : blocks.height() / side(); }
    // Whether tiles of `tile` base texels fit a base of this size.
    static bool fits(int base_width, int base_height, int tile) {
        return tile > 0 && base_width % tile == 0 && base_height % tile == 0;
    }
};

// Calls visit(block, u, v) for every kept block holding fine texel (i, j) of a base `base_height`
// rows high, the fine texel's own tile first: its own tile's (u = i mod T), the left
// neighbour's (u = T) when i is a tile's first column (column 0: the last tile, round the
// seam); rows likewise, and a block of the last tile row holds row fh - 1 again at v = T.
template <typename Visit>
void for_each_block_holding(const FineTiles& f, int base_height, int i, int j, const Visit& visit) {
    const int t = f.tile * f.factor, fh = base_height * f.factor;
    const int xs[2][2] = {{i / t, i % t}, {(i / t + f.tiles_x - 1) % f.tiles_x, t}};
    const int ys[3][2] = {{j / t, j % t}, {j / t - 1, t}, {j / t, t}};
    for (int cx = 0; cx < 2; ++cx) {
        if (cx == 1 && i % t != 0) continue;
        for (int cy = 0; cy < 3; ++cy) {
            if (cy == 1 && (j % t != 0 || j == 0)) continue;
            if (cy == 2 && j != fh - 1) continue;
            const int k = f.slot[std::size_t(ys[cy][0]) * std::size_t(f.tiles_x) + std::size_t(xs[cx][0])];
            if (k >= 0) visit(k, xs[cx][1], ys[cy][1]);
        }
    }
}

// Bilinear lookup of a map with fine tiles at direction d (unit): the fine grid's where d's fine
// cell lies in a kept tile, the base's elsewhere. With no tiles, sample_bilinear of the base.
Rgb sample_bilinear(const HdrImage& base, const FineTiles& fine, const glm::dvec3& d);

// The whole fine grid: the kept blocks' texels where a block holds one (its last column and row
// too), elsewhere the lookup above at the texel's centre (the base's bilinear lookup). For
// readers that take one image (the renderer uploads it as a texture; glint compare reads it
// against a reference). Bilinear reads of it equal the lookup above inside the kept tiles;
// outside, they interpolate the base's lookups again (an error a little above the base's own
// lookups': in a one-dimensional quadratic, 4 % more RMS for a factor of 4, 26 % for 2, the
// same worst). threads 0: all cores.
HdrImage expand(const HdrImage& base, const FineTiles& fine, int threads = 0);

// Throws InputError naming `what` when the tiles do not fit the base (sizes, slots, blocks).
void check_fine_tiles(const HdrImage& base, const FineTiles& fine, const std::string& what);

}  // namespace glint
