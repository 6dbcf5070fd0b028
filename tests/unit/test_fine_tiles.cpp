// Fine tiles (core/fine_tiles.hpp, convolution Options::fine_tiles): a map delivered as its sum
// grid plus tiles of a finer grid only where lookups of the sum grid would miss. The lookups
// against the whole finer grid, the files, and the engine's maps against exact sums off-grid.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>

#include "appliance/convolution/convolution.hpp"
#include "appliance/convolution/offgrid.hpp"
#include "appliance/convolution/output_grid.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/fine_tiles.hpp"
#include "appliance/core/fine_tiles_io.hpp"

namespace glint {
namespace {

namespace fs = std::filesystem;

HdrImage random_image(int w, int h, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(0.0f, 10.0f);
    HdrImage m(w, h);
    for (float& v : m.data()) v = u(rng);
    return m;
}

// Tiles of `fine` (the whole finer grid) over `base` at the tiles marked in `kept` (row-major).
FineTiles tiles_from(const HdrImage& base, const HdrImage& fine, int factor, int tile, const std::vector<char>& kept) {
    convolution::FineTilePlan plan;
    plan.factor = factor;
    plan.tile = tile;
    plan.tiles_x = base.width() / tile;
    plan.tiles_y = base.height() / tile;
    plan.kept = kept;
    // make_fine_tiles resamples a map; here the blocks are filled from `fine` texel by texel.
    FineTiles f = convolution::make_fine_tiles(base, plan, 1, nullptr, nullptr);
    const convolution::TexelSelection all = convolution::fine_tile_texels(plan, {base.width(), base.height()});
    for (std::size_t k = 0; k < all.rows.size(); ++k)
        for (const auto& [a, b] : all.runs[k])
            for (int i = a; i < b; ++i)
                convolution::set_fine_texel(f, {base.width(), base.height()}, i, all.rows[k], fine.row(all.rows[k]) + 3 * i);
    return f;
}

TEST(FineTiles, LookupsInTilesAreTheFineGridsAndElsewhereTheBases) {
    // A 32x16 base, a 4x finer grid of unrelated values, tiles of 4 texels: every kept tile's
    // corner tiles at the seam and the poles included. Lookups at random directions read the fine
    // grid where their fine cell's tile is kept and the base elsewhere, to float rounding.
    const int factor = 4, tile = 4;
    const HdrImage base = random_image(32, 16, 1);
    const HdrImage fine = random_image(128, 64, 2);
    std::vector<char> kept(8 * 4, 0);
    for (int k : {0, 7, 8 * 3, 8 * 3 + 7, 8 + 3, 8 * 2 + 4}) kept[std::size_t(k)] = 1;
    const FineTiles f = tiles_from(base, fine, factor, tile, kept);
    ASSERT_EQ(f.count(), 6);
    check_fine_tiles(base, f, "test");
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    int in_tiles = 0, outside = 0;
    for (int s = 0; s < 20000; ++s) {
        glm::dvec3 d(u(rng), u(rng), u(rng));
        if (glm::length(d) < 1e-3) continue;
        d = glm::normalize(d);
        const TexelCoord t = direction_to_texel(d, 128, 64);
        int x0 = int(std::floor(t.x - 0.5));
        x0 = ((x0 % 128) + 128) % 128;
        const int y0 = int(std::floor(std::clamp(t.y - 0.5, 0.0, 63.0)));
        const bool kept_cell = kept[std::size_t((y0 / 16) * 8 + x0 / 16)] != 0;
        const Rgb got = sample_bilinear(base, f, d);
        const Rgb want = kept_cell ? sample_bilinear(fine, d) : sample_bilinear(base, d);
        (kept_cell ? in_tiles : outside)++;
        ASSERT_NEAR(got.r, want.r, 1e-4) << s;
        ASSERT_NEAR(got.g, want.g, 1e-4) << s;
        ASSERT_NEAR(got.b, want.b, 1e-4) << s;
    }
    EXPECT_GT(in_tiles, 500);
    EXPECT_GT(outside, 500);
    // The expansion holds the fine grid's texels wherever a kept block holds them (a block's
    // last column and row included: the next tile's first), and the lookups at the centres
    // elsewhere.
    const HdrImage e = expand(base, f, 2);
    ASSERT_EQ(e.width(), 128);
    const auto is_kept = [&](int tx, int ty) { return ty >= 0 && kept[std::size_t(ty * 8 + (tx + 8) % 8)] != 0; };
    int held = 0;
    for (int j = 0; j < 64; ++j)
        for (int i = 0; i < 128; ++i) {
            const int tx = i / 16, ty = j / 16;
            const bool left = i % 16 == 0, up = j % 16 == 0;
            const bool in_block = is_kept(tx, ty) || (left && is_kept(tx - 1, ty)) || (up && is_kept(tx, ty - 1)) ||
                                  (left && up && is_kept(tx - 1, ty - 1));
            held += in_block ? 1 : 0;
            const Rgb want = in_block ? fine.at(i, j) : sample_bilinear(base, f, texel_direction(i, j, 128, 64));
            ASSERT_NEAR(e.at(i, j).g, want.g, 1e-4) << i << "," << j;
        }
    EXPECT_GT(held, 6 * 16 * 16);
}

TEST(FineTiles, FilesRoundTripAndBadListingsAreRefusedNamingTheKey) {
    const HdrImage base = random_image(32, 16, 4);
    const HdrImage fine = random_image(64, 32, 5);
    std::vector<char> kept(4 * 2, 0);
    kept[1] = kept[6] = 1;
    const FineTiles f = tiles_from(base, fine, 2, 8, kept);
    const fs::path dir = fs::temp_directory_path() / ("glint_fine_tiles_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const nlohmann::json entry = fine_tiles_to_json(f, "m.tiles.exr");
    save_exr(dir / "m.tiles.exr", f.blocks, ExrCompression::None);
    const FineTiles back = load_fine_tiles(entry, dir, base, "report.json: m");
    EXPECT_EQ(back.slot, f.slot);
    EXPECT_EQ(back.blocks.data(), f.blocks.data());
    EXPECT_TRUE(load_fine_tiles(nlohmann::json(), dir, base, "x").empty());
    const auto refused = [&](nlohmann::json bad, const std::string& says) {
        try {
            load_fine_tiles(bad, dir, base, "report.json: m");
            ADD_FAILURE() << "accepted " << bad.dump();
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
        }
    };
    nlohmann::json bad = entry;
    bad["tiles"][0] = {4, 0};
    refused(bad, "outside");
    bad = entry;
    bad["tiles"][1] = bad["tiles"][0];
    refused(bad, "twice");
    bad = entry;
    bad["factor"] = 64;  // a 2048x1024 finer grid of a 32x16 map would be fine, but not past 16
    refused(bad, "\"factor\" 64");
    bad = entry;
    bad["tile"] = 5;
    refused(bad, "does not divide");
    bad = entry;
    bad["file"] = "../m.tiles.exr";
    refused(bad, "beside report.json");
    bad = entry;
    bad.erase("factor");
    refused(bad, "\"factor\"");
    bad = entry;
    bad["tiles"].push_back({0, 0});  // three tiles listed, two blocks in the file
    refused(bad, "blocks");
    fs::remove_all(dir);
}

HdrImage field_with_lights(int w, int h) {
    // A smooth floor with two small lights: one in the open, one on the seam near the pole.
    HdrImage m(w, h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const glm::dvec3 d = texel_direction(i, j, w, h);
            const float v = float(0.5 + 0.4 * d.y + 0.2 * d.x);
            m.set(i, j, {v, 0.8f * v, 0.6f * v});
        }
    m.set(w / 3, h / 2 - 3, {5000.f, 4000.f, 3000.f});
    m.set(w / 3 + 1, h / 2 - 3, {2000.f, 2000.f, 2000.f});
    m.set(0, 2, {8000.f, 6000.f, 5000.f});
    return m;
}

TEST(FineTiles, TiledMapsAreWithinTheirPredictionOffGridAndMatchTheWholeFinerGridInTheirTiles) {
    // Sharp lobes around small lights need a finer grid than they are summed on: with
    // fine_tiles the engine keeps it in a few tiles, predicts within the tolerance, and its
    // lookups at random directions are within that prediction; in the tiles its texels are the
    // whole finer grid's (same resampling, bright lobes and exact patches), and the rest of the
    // map is the sum grid.
    const HdrImage env = field_with_lights(256, 128);
    std::vector<convolution::MapRequest> maps;
    for (double n : {300.0, 1000.0, 2000.0, 8000.0}) maps.push_back(convolution::MapRequest::make_phong(n, std::to_string(int(n))));
    convolution::Options whole;
    whole.threads = 2;
    convolution::Options tiled = whole;
    tiled.fine_tiles = true;
    const auto full = convolution::convolve(env, maps, whole);
    const auto tiles = convolution::convolve(env, maps, tiled);
    int with_tiles = 0, matched = 0, finer_than_whole = 0;
    for (std::size_t k = 0; k < maps.size(); ++k) {
        const convolution::MapResult& r = tiles[k];
        const convolution::OffGridError e = convolution::measure_offgrid_error(
            env, r.image, r.request.shininess, 2048, 11, 2, r.plan.lookup, &r.fine);
        std::printf("[  report  ] %-5s %dx%d, %d tiles (whole grid %dx%d) predicted %.4f off-grid %.4f +- %.4f, "
                    "worst %.3f\n",
                    r.request.label.c_str(), r.image.width(), r.image.height(), r.fine.count(),
                    full[k].image.width(), full[k].image.height(), r.plan.predicted_error, e.weighted_relative_rms,
                    e.rms_standard_error, e.worst_texel);
        EXPECT_LE(r.plan.predicted_error, tiled.tolerance) << r.request.label;
        EXPECT_LE(e.weighted_relative_rms, std::max(tiled.tolerance, 1.25 * r.plan.predicted_error) +
                                               3 * e.rms_standard_error)
            << r.request.label;
        if (r.fine.empty()) continue;
        ++with_tiles;
        EXPECT_NE(r.plan.size_reason.find("tiles of"), std::string::npos) << r.plan.size_reason;
        EXPECT_LT(r.fine.count() * 4, r.fine.tiles_x * r.fine.tiles_y) << "a few tiles, not the whole map";
        EXPECT_LE(e.worst_texel, 0.05) << r.request.label;
        if (r.image.width() * r.fine.factor != full[k].image.width()) {
            // Tiles finer than a whole grid goes (the lookups measured in tiles as fine as the
            // whole grid missed their worst share): nothing to match texel by texel.
            EXPECT_EQ(r.image.width() * r.fine.factor, 2 * full[k].image.width()) << r.request.label;
            ++finer_than_whole;
            continue;
        }
        ++matched;
        // In the tiles: the whole finer grid's texels.
        const int fw = full[k].image.width(), fh = full[k].image.height();
        const int t = r.fine.tile * r.fine.factor;
        double worst = 0;
        for (int j = 0; j < fh; ++j)
            for (int i = 0; i < fw; ++i) {
                if (r.fine.slot[std::size_t((j / t) * r.fine.tiles_x + i / t)] < 0) continue;
                const float* a = convolution::fine_texel(r.fine, {r.image.width(), r.image.height()}, i, j);
                const float* b = full[k].image.row(j) + 3 * i;
                for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(double(a[c]) - b[c]) / (1e-3 + std::abs(b[c])));
            }
        EXPECT_LT(worst, 1e-4) << r.request.label;
    }
    EXPECT_GE(with_tiles, 2);
    EXPECT_GE(matched, 1);
    // n = 1000 round the light by the pole: 4x tiles measured 4.6 % worst between their texels
    // (the share is 4 %), so it goes to 8x (0.6 % worst off-grid; 3.0 % at 4x).
    EXPECT_GE(finer_than_whole, 1);
}

}  // namespace
}  // namespace glint
