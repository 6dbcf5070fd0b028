// Fine tiles in files (fine_tiles.hpp): glint convolve writes a map's blocks as <map>.tiles.exr
// and describes them in report.json's "fine_tiles" of the map:
//   {"file": "phong_5120.tiles.exr", "factor": 4, "tile": 4, "tiles": [[tx, ty], ...]}
// with the tiles in the blocks' order (tile (tx, ty) of the map's (width / tile) x
// (height / tile), block k = rows [k side, (k + 1) side) of the file, side = tile factor + 1).
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "appliance/core/fine_tiles.hpp"

namespace glint {

inline constexpr const char* kFineTilesSuffix = ".tiles.exr";

nlohmann::json fine_tiles_to_json(const FineTiles& tiles, const std::string& file);

// The tiles of `base` described by `entry` (null: none), their blocks read from the file it
// names in `dir`. Throws InputError naming `what` (e.g. "report.json: phong_5120") and the key
// or file at fault.
FineTiles load_fine_tiles(const nlohmann::json& entry, const std::filesystem::path& dir, const HdrImage& base,
                          const std::string& what);

}  // namespace glint
