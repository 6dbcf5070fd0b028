// Reflection maps with fine tiles in the renderer (appliance/render/tiled_map.hpp, the shader's
// equirect_tiled): the packed texture's layout, and the shader's lookup through the tiles against
// core's sample_bilinear(base, fine, d) at the AOVs' own reflection directions.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <random>
#include <vector>

#include "appliance/convolution/convolution.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/fine_tiles.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "appliance/render/renderer.hpp"
#include "appliance/render/tiled_map.hpp"
#include "gpu_fixture.hpp"

namespace glint {
namespace {

namespace fs = std::filesystem;

// A base of random texels and kept tiles of other random texels (a jump at every kept tile's
// edge, so a lookup that reads the wrong tile, block, row or column shows), with kept tiles on
// the seam's both sides and in the first and last tile rows (the poles).
struct TiledWorld {
    HdrImage base;
    FineTiles fine;
};
TiledWorld make_tiled_world(int width, int height, int factor, int tile, unsigned seed, double keep_share = 0.4) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> value(0.5f, 4.0f);
    TiledWorld w{HdrImage(width, height), {}};
    for (float& v : w.base.data()) v = value(rng);
    FineTiles& f = w.fine;
    f.factor = factor;
    f.tile = tile;
    f.tiles_x = width / tile;
    f.tiles_y = height / tile;
    f.slot.assign(std::size_t(f.tiles_x) * std::size_t(f.tiles_y), -1);
    std::bernoulli_distribution keep(keep_share);
    int count = 0;
    for (int ty = 0; ty < f.tiles_y; ++ty)
        for (int tx = 0; tx < f.tiles_x; ++tx) {
            const bool edge = (tx == 0 || tx == f.tiles_x - 1) && (ty == 0 || ty == f.tiles_y - 1 || ty == 1);
            if (edge || keep(rng)) f.slot[std::size_t(ty * f.tiles_x + tx)] = count++;
        }
    // Blocks in a shuffled order, so that the slot table, not the tiles' order, finds them.
    std::vector<int> order(static_cast<std::size_t>(count));
    for (int k = 0; k < count; ++k) order[std::size_t(k)] = k;
    std::shuffle(order.begin(), order.end(), rng);
    for (int& s : f.slot)
        if (s >= 0) s = order[std::size_t(s)];
    f.blocks = HdrImage(f.side(), f.side() * count);
    for (float& v : f.blocks.data()) v = value(rng) * 2.0f;
    check_fine_tiles(w.base, f, "test world");
    return w;
}

class RenderTiles : public test::GpuTest {};

TEST(RenderTiledMap, PacksTheBaseSlotsAndBlocks) {
    const TiledWorld w = make_tiled_world(64, 32, 4, 4, 7);
    const auto layout = render::tiled_map_layout(64, 32, w.fine);
    ASSERT_TRUE(layout);
    EXPECT_EQ(layout->slot_row, 32);
    EXPECT_EQ(layout->atlas_row, 34);  // 16 x 8 slots: two rows of 64
    EXPECT_EQ(layout->per_row, 64 / 17);
    const HdrImage packed = render::pack_tiled_map(w.base, w.fine, *layout);
    ASSERT_EQ(packed.width(), 64);
    ASSERT_EQ(packed.height(), layout->height);
    for (int j = 0; j < 32; ++j)
        for (int i = 0; i < 64; ++i) ASSERT_EQ(packed.at(i, j).g, w.base.at(i, j).g);
    for (std::size_t k = 0; k < w.fine.slot.size(); ++k)
        ASSERT_EQ(packed.at(int(k % 64), layout->slot_row + int(k / 64)).r, float(w.fine.slot[k])) << k;
    const int side = w.fine.side();
    for (int k = 0; k < w.fine.count(); ++k)
        for (int v = 0; v < side; v += side - 1)
            for (int u = 0; u < side; u += side - 1)
                ASSERT_EQ(packed.at((k % layout->per_row) * side + u, layout->atlas_row + (k / layout->per_row) * side + v).b,
                          w.fine.blocks.at(u, k * side + v).b)
                    << "block " << k;
    // A block wider than the base: no layout (the caller expands the map instead).
    const TiledWorld narrow = make_tiled_world(16, 8, 4, 4, 8);
    EXPECT_FALSE(render::tiled_map_layout(16, 8, narrow.fine));
    // So many blocks that the packed image would be taller than the whole 4096x2048 finer grid
    // of a 1024x512 map at 4x (and than 2048 rows): none either.
    FineTiles many;
    many.factor = 4;
    many.tile = 4;
    many.tiles_x = 256;
    many.tiles_y = 128;
    many.slot.assign(256 * 128, -1);
    const int count = 90 * (1024 / 17);  // 90 bands of 17 rows: 512 + 32 + 1530 rows > 2048
    for (int k = 0; k < count; ++k) many.slot[std::size_t(k)] = k;
    many.blocks = HdrImage(17, 17 * count);
    const auto tall = render::tiled_map_layout(1024, 512, many);
    EXPECT_FALSE(tall) << "a packed image of " << (tall ? tall->height : 0) << " rows";
    many.slot.assign(256 * 128, -1);
    for (int k = 0; k < 80 * 60; ++k) many.slot[std::size_t(k)] = k;
    many.blocks = HdrImage(17, 17 * 80 * 60);
    const auto fits = render::tiled_map_layout(1024, 512, many);
    ASSERT_TRUE(fits);
    EXPECT_EQ(fits->height, 512 + 32 + 80 * 17);
}

// The shader's lookup through the tiles is core's: a sphere's reflection directions cover the
// whole sphere (seam and poles too). The shader's float coordinates (atan on llvmpipe, ~1e-4 of a
// fine texel) times the random texels' steps between neighbours (up to 16x) allow 1e-3; measured
// 4.9e-4 (factor 2) and 9.1e-4 (factor 4), factor 8 since tiles may be that fine. A float coordinate may also put a direction at a kept
// tile's edge into the other cell than double does, where the texels jump: at most 0.2 % of
// pixels may be off by more (none were). Reading the wrong row of a block, or the neighbour's
// tile, puts 4-40 % of the pixels off.
TEST_F(RenderTiles, ShaderReadsTheTilesAsCoreDoes) {
    for (const int factor : {2, 4, 8}) {
        // At 8x, fewer tiles: 40 % of them would pack taller than the 2048 rows every GPU holds.
        const TiledWorld w = make_tiled_world(128, 64, factor, 4, 11u + unsigned(factor), factor == 8 ? 0.25 : 0.4);
        const render::Material m = render::parse_material("glossy:160");
        render::ShadingMaps maps;
        maps.set_reflection(m, w.base, "test");
        render::attach_fine_tiles(maps.reflections[0], w.fine);
        ASSERT_FALSE(maps.reflections[0].fine.empty());
        ASSERT_GT(maps.reflections[0].texture.height(), w.base.height());

        render::Renderer r(render::make_uv_sphere(), m, maps, 384, 384);
        r.set_background_black();
        r.draw_scene();
        const render::Aovs a = r.read_aovs();
        // A fine texel at 8x is half as wide as at 4x, so the same float coordinate error is
        // twice as much of it (measured 1.96e-3).
        const double allowed = factor <= 4 ? 2e-3 : 4e-3;
        long long pixels = 0, off = 0, in_tiles = 0, far_off = 0;
        double worst_kept = 0;
        for (std::size_t k = 0; k < std::size_t(a.width) * std::size_t(a.height); ++k) {
            if (a.radiance[4 * k + 3] == 0) continue;
            ++pixels;
            const glm::dvec3 d(a.reflect[4 * k], a.reflect[4 * k + 1], a.reflect[4 * k + 2]);
            const Rgb want = sample_bilinear(w.base, w.fine, d);
            const Rgb base_only = sample_bilinear(w.base, d);
            const double want_v[3] = {want.r, want.g, want.b};
            double e = 0;
            for (int c = 0; c < 3; ++c)
                e = std::max(e, std::abs(a.radiance[4 * k + std::size_t(c)] - want_v[c]) / want_v[c]);
            if (std::abs(want.r - base_only.r) > 1e-3f) ++in_tiles;
            if (e > 0.05) ++far_off;
            if (e > allowed) ++off;
            else worst_kept = std::max(worst_kept, e);
        }
        std::printf("[          ] factor %d: %lld pixels, %lld read the tiles, %lld off by more than %.0e, %lld by more than "
                    "5 %% (worst of the rest %.2e)\n",
                    factor, pixels, in_tiles, off, allowed, far_off, worst_kept);
        EXPECT_GT(pixels, 50000);
        EXPECT_GT(in_tiles, pixels / 8);   // the tiles are read, not only the base
        EXPECT_LT(off, pixels / 500);      // at most 0.2 % of pixels at a cell's edge
    }
}

// The engine's own tiles end to end: a sharp lobe on a full-size world, convolved as glint render
// convolves (fine tiles on), keeps its tiles (not the whole finer grid) and the frame reads them.
TEST_F(RenderTiles, EngineTilesAreRenderedThroughTheShader) {
    const HdrImage env = load_exr(fs::path(GLINT_BLENDER_WORLDS) / "courtyard.exr").image;
    const render::Material m = render::parse_material("glossy:5120");
    convolution::Options o;
    o.tolerance = 0.01;
    o.fine_tiles = true;
    const render::ShadingMaps maps = render::convolve_maps(env, m, o);
    ASSERT_EQ(maps.reflections.size(), 1u);
    const render::ReflectionMap& map = maps.reflections[0];
    ASSERT_FALSE(map.fine.empty()) << "courtyard's n = 5120 map came without fine tiles: " << map.from;
    EXPECT_EQ(map.image.width(), env.width());  // the sum grid, not the whole finer grid
    const std::size_t whole_bytes = map.image.texel_count() * std::size_t(map.fine.factor * map.fine.factor) * 16;
    const std::size_t packed_bytes = map.texture.texel_count() * 16;
    std::printf("[          ] courtyard n 5120: %d tiles of %d at factor %d; texture %dx%d (%.1f MB) against the "
                "whole finer grid's %.1f MB\n",
                map.fine.count(), int(map.fine.slot.size()), map.fine.factor, map.texture.width(), map.texture.height(),
                double(packed_bytes) / 1e6, double(whole_bytes) / 1e6);
    EXPECT_LT(packed_bytes * 2, whole_bytes);  // 11.1 against 33.6 MB at factor 2 (2026-12-06)

    render::Renderer r(render::make_uv_sphere(), m, maps, 256, 256);
    r.set_background_black();
    r.draw_scene();
    const render::Aovs a = r.read_aovs();
    double num = 0, den = 0, worst = 0, mean = 0;
    long long pixels = 0;
    for (std::size_t k = 0; k < std::size_t(a.width) * std::size_t(a.height); ++k)
        if (a.radiance[4 * k + 3] != 0) mean += a.radiance[4 * k + 1], ++pixels;
    mean /= double(std::max(1LL, pixels));
    for (std::size_t k = 0; k < std::size_t(a.width) * std::size_t(a.height); ++k) {
        if (a.radiance[4 * k + 3] == 0) continue;
        const glm::dvec3 d(a.reflect[4 * k], a.reflect[4 * k + 1], a.reflect[4 * k + 2]);
        const Rgb want = sample_bilinear(map.image, map.fine, d);
        const double w[3] = {want.r, want.g, want.b};
        for (int c = 0; c < 3; ++c) {
            const double e = a.radiance[4 * k + std::size_t(c)] - w[c];
            num += e * e;
            den += w[c] * w[c];
            worst = std::max(worst, std::abs(e) / std::max(w[c], mean));
        }
    }
    const double rms = std::sqrt(num / den);
    std::printf("[          ] against core's lookup through the tiles: rms %.2e, worst %.2e over %lld pixels\n", rms,
                worst, pixels);
    EXPECT_GT(pixels, 30000);
    EXPECT_LT(rms, 1e-4);
    EXPECT_LT(worst, 2e-3);
}

}  // namespace
}  // namespace glint
