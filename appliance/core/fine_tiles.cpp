// Fine tiles: lookups, expansion to the whole fine grid, checks (fine_tiles.hpp).
#include "appliance/core/fine_tiles.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"

namespace glint {
namespace {

// The bilinear cell of continuous texel coordinates (t.x, t.y) on a w x h grid, as
// sample_bilinear (equirect.cpp) takes it: wrapped in azimuth, clamped in polar angle.
struct Cell {
    int x0, x1, y0, y1;
    double ax, ay;
};
Cell bilinear_cell(double tx, double ty, int w, int h) {
    const double x = tx - 0.5;
    const double y = std::clamp(ty - 0.5, 0.0, double(h - 1));
    const double fx0 = std::floor(x), fy0 = std::floor(y);
    Cell c;
    c.ax = x - fx0;
    c.ay = y - fy0;
    c.x0 = int(fx0) % w;
    if (c.x0 < 0) c.x0 += w;
    c.x1 = (c.x0 + 1) % w;
    c.y0 = int(fy0);
    c.y1 = std::min(c.y0 + 1, h - 1);
    return c;
}

Rgb blend(const float* p00, const float* p10, const float* p01, const float* p11, double ax, double ay) {
    float v[3];
    for (int c = 0; c < 3; ++c) {
        const double top = (1 - ax) * p00[c] + ax * p10[c];
        const double bottom = (1 - ax) * p01[c] + ax * p11[c];
        v[c] = float((1 - ay) * top + ay * bottom);
    }
    return {v[0], v[1], v[2]};
}

// The block of the fine cell with top-left corner (x0, y0) of the fine grid, or -1.
int block_of(const FineTiles& f, int x0, int y0) {
    const int t = f.tile * f.factor;
    return f.slot[std::size_t(y0 / t) * std::size_t(f.tiles_x) + std::size_t(x0 / t)];
}

// The lookup at continuous fine coordinates: the block's four texels or the base's bilinear
// lookup at the same direction (base coordinates = fine / factor).
Rgb lookup(const HdrImage& base, const FineTiles& f, double fx, double fy) {
    const int fw = base.width() * f.factor, fh = base.height() * f.factor;
    const Cell c = bilinear_cell(fx, fy, fw, fh);
    const int k = block_of(f, c.x0, c.y0);
    if (k < 0) {
        const Cell b = bilinear_cell(fx / f.factor, fy / f.factor, base.width(), base.height());
        return blend(base.row(b.y0) + 3 * b.x0, base.row(b.y0) + 3 * b.x1, base.row(b.y1) + 3 * b.x0,
                     base.row(b.y1) + 3 * b.x1, b.ax, b.ay);
    }
    // Within the block: its own columns u and rows v (the wrapped column x0 + 1 = 0 and the
    // clamped row are the block's last column and row, stored as such).
    const int t = f.tile * f.factor;
    const int u = c.x0 % t, v = c.y0 % t;
    const int v1 = c.y1 == c.y0 ? v : v + 1;
    const float* r0 = f.blocks.row(k * f.side() + v);
    const float* r1 = f.blocks.row(k * f.side() + v1);
    return blend(r0 + 3 * u, r0 + 3 * (u + 1), r1 + 3 * u, r1 + 3 * (u + 1), c.ax, c.ay);
}

}  // namespace

Rgb sample_bilinear(const HdrImage& base, const FineTiles& fine, const glm::dvec3& d) {
    if (fine.empty()) return sample_bilinear(base, d);
    const TexelCoord t = direction_to_texel(d, base.width() * fine.factor, base.height() * fine.factor);
    return lookup(base, fine, t.x, t.y);
}

HdrImage expand(const HdrImage& base, const FineTiles& fine, int threads) {
    if (fine.empty()) return base;
    const int fw = base.width() * fine.factor, fh = base.height() * fine.factor;
    HdrImage out(fw, fh, HdrImage::Unwritten{});
    parallel_for(fh, threads > 0 ? threads : hardware_threads(), [&](int j) {
        float* o = out.row(j);
        for (int i = 0; i < fw; ++i) {
            // A texel some kept block holds is that block's (also on a block's last column or
            // row, whose cell belongs to the next tile); any other is the lookup there, the
            // sum grid's.
            const float* held = nullptr;
            for_each_block_holding(fine, base.height(), i, j, [&](int k, int u, int v) {
                if (!held) held = fine.blocks.row(k * fine.side() + v) + 3 * u;
            });
            if (held) {
                std::copy_n(held, 3, o + 3 * i);
                continue;
            }
            const Rgb v = lookup(base, fine, i + 0.5, j + 0.5);
            o[3 * i] = v.r;
            o[3 * i + 1] = v.g;
            o[3 * i + 2] = v.b;
        }
    });
    return out;
}

void check_fine_tiles(const HdrImage& base, const FineTiles& f, const std::string& what) {
    if (f.tile == 0 && f.blocks.empty()) return;
    const auto fail = [&](const std::string& why) { throw InputError(what + ": fine tiles " + why); };
    if (f.factor < 2 || f.factor > FineTiles::kMaxFactor)
        fail("refine by " + std::to_string(f.factor) + ", not 2 to " + std::to_string(FineTiles::kMaxFactor));
    if (static_cast<long long>(base.height()) * f.factor > FineTiles::kMaxFineHeight)
        fail("make a finer grid of " + std::to_string(static_cast<long long>(base.height()) * f.factor) +
             " rows, more than " + std::to_string(FineTiles::kMaxFineHeight));
    if (!FineTiles::fits(base.width(), base.height(), f.tile))
        fail("of " + std::to_string(f.tile) + " texels do not divide the base's " + std::to_string(base.width()) +
             "x" + std::to_string(base.height()));
    if (f.tiles_x != base.width() / f.tile || f.tiles_y != base.height() / f.tile ||
        f.slot.size() != std::size_t(f.tiles_x) * std::size_t(f.tiles_y))
        fail("table is not one slot per tile");
    if (f.blocks.width() != f.side() || f.blocks.height() % f.side() != 0)
        fail("blocks are " + std::to_string(f.blocks.width()) + "x" + std::to_string(f.blocks.height()) +
             ", not a stack of " + std::to_string(f.side()) + "x" + std::to_string(f.side()));
    std::vector<char> used(std::size_t(f.count()), 0);
    for (int s : f.slot) {
        if (s < -1 || s >= f.count()) fail("name block " + std::to_string(s) + " of " + std::to_string(f.count()));
        if (s >= 0) {
            if (used[std::size_t(s)]) fail("use block " + std::to_string(s) + " twice");
            used[std::size_t(s)] = 1;
        }
    }
}

}  // namespace glint
