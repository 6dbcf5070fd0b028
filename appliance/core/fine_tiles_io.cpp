// Fine tiles in report.json and <map>.tiles.exr (fine_tiles_io.hpp).
#include "appliance/core/fine_tiles_io.hpp"

#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"

namespace glint {

nlohmann::json fine_tiles_to_json(const FineTiles& f, const std::string& file) {
    nlohmann::json tiles = nlohmann::json::array();
    std::vector<std::pair<int, int>> order(std::size_t(f.count()), {-1, -1});
    for (std::size_t k = 0; k < f.slot.size(); ++k)
        if (f.slot[k] >= 0) order[std::size_t(f.slot[k])] = {int(k) % f.tiles_x, int(k) / f.tiles_x};
    for (const auto& [tx, ty] : order) tiles.push_back({tx, ty});
    return {{"file", file}, {"factor", f.factor}, {"tile", f.tile}, {"tiles", tiles}};
}

FineTiles load_fine_tiles(const nlohmann::json& entry, const std::filesystem::path& dir, const HdrImage& base,
                          const std::string& what) {
    if (entry.is_null()) return FineTiles{};
    const auto fail = [&](const std::string& why) { throw InputError(what + ": \"fine_tiles\" " + why); };
    if (!entry.is_object()) fail("is not an object");
    for (const char* key : {"file", "factor", "tile", "tiles"})
        if (!entry.contains(key)) fail(std::string("has no \"") + key + "\"");
    if (!entry["file"].is_string()) fail("\"file\" is not a string");
    if (!entry["factor"].is_number_integer() || !entry["tile"].is_number_integer())
        fail("\"factor\" and \"tile\" must be integers");
    if (!entry["tiles"].is_array()) fail("\"tiles\" is not a list");
    const std::string file = entry["file"].get<std::string>();
    if (file.empty() || file.find('/') != std::string::npos || file == "." || file == "..")
        fail("\"file\" must name a file beside report.json, not '" + file + "'");
    FineTiles f;
    const long long factor = entry["factor"].get<long long>(), tile = entry["tile"].get<long long>();
    if (factor < 2 || factor > FineTiles::kMaxFactor || base.height() * factor > FineTiles::kMaxFineHeight)
        fail("\"factor\" " + std::to_string(factor) + " is not 2 to " + std::to_string(FineTiles::kMaxFactor) +
             " with a finer grid of at most " + std::to_string(FineTiles::kMaxFineHeight) + " rows");
    if (tile < 1 || tile > 4096 || !FineTiles::fits(base.width(), base.height(), int(tile)))
        fail("\"tile\" " + std::to_string(tile) + " does not divide the map's " + std::to_string(base.width()) + "x" +
             std::to_string(base.height()));
    f.factor = int(factor);
    f.tile = int(tile);
    f.tiles_x = base.width() / f.tile;
    f.tiles_y = base.height() / f.tile;
    f.slot.assign(std::size_t(f.tiles_x) * std::size_t(f.tiles_y), -1);
    int k = 0;
    for (const auto& t : entry["tiles"]) {
        if (!t.is_array() || t.size() != 2 || !t[0].is_number_integer() || !t[1].is_number_integer())
            fail("tile " + std::to_string(k) + " is not [tx, ty]");
        const long long tx = t[0].get<long long>(), ty = t[1].get<long long>();
        if (tx < 0 || tx >= f.tiles_x || ty < 0 || ty >= f.tiles_y)
            fail("tile " + std::to_string(k) + " [" + std::to_string(tx) + ", " + std::to_string(ty) +
                 "] is outside the map's " + std::to_string(f.tiles_x) + "x" + std::to_string(f.tiles_y) + " tiles");
        int& slot = f.slot[std::size_t(ty) * std::size_t(f.tiles_x) + std::size_t(tx)];
        if (slot >= 0) fail("names tile [" + std::to_string(tx) + ", " + std::to_string(ty) + "] twice");
        slot = k++;
    }
    if (k == 0) fail("has no tiles");
    f.blocks = load_exr((dir / file).string()).image;
    if (f.blocks.width() != f.side() || static_cast<long long>(f.blocks.height()) != static_cast<long long>(k) * f.side())
        throw InputError((dir / file).string() + ": " + std::to_string(f.blocks.width()) + "x" +
                         std::to_string(f.blocks.height()) + ", not " + std::to_string(k) + " blocks of " +
                         std::to_string(f.side()) + "x" + std::to_string(f.side()) + " (" + what + ")");
    check_fine_tiles(base, f, what);
    return f;
}

}  // namespace glint
