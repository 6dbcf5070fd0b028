// The kiosk's last scene in the state directory (docs/state.md): the visitor's environment map
// and its coverage, one state item (state_store.hpp) at <state.dir>/scene, so that a restart can
// show the last lit scene and a power cut never leaves the new map beside the old coverage.
//
// The capture writes into a staging directory beside it (<state.dir>/.scene.capture/); once the
// map is read back, the two files are committed as one new version of the item. A replay keeps
// its own output directory as before (no store: it is a measurement, not the appliance's state).
#pragma once

#include <filesystem>
#include <optional>

#include "appliance/core/hdr_image.hpp"
#include "appliance/core/state_store.hpp"

namespace glint {

inline constexpr const char* kSceneEnv = "env.exr";
inline constexpr const char* kSceneCoverage = "env.coverage.exr";

// Where the capture writes the visitor's env.exr (and, beside it, env.coverage.exr): the staging
// directory of `scene_dir` (emptied and created: call it when a capture starts), or `scene_dir`
// itself for a replay. Never throws: when the state directory cannot take the capture
// (read-only) it is a directory under the temporary directory, so that the visitor still gets
// the map (its commit then fails and is logged).
std::filesystem::path scene_capture_path(const std::filesystem::path& scene_dir, bool replayed);

// Reads the captured map back and, live, commits it with its coverage as the new version of the
// scene item. A failed commit (disk full, read-only) is logged and kept for
// state::last_save_error(); the map is still returned (the visitor sees it; the old scene stays
// on disk). Throws what load_exr throws for an unreadable capture.
HdrImage take_captured_scene(const std::filesystem::path& scene_dir, bool replayed, const state::Log& log);

// The last scene's env.exr if the item verifies (checksums, and the map loads), else nullopt;
// a faulty scene is set aside and logged (state::load_item).
std::optional<std::filesystem::path> last_scene_env(const std::filesystem::path& scene_dir, const state::Log& log);
// ... and the map itself (nullopt when there is none or it did not verify).
std::optional<HdrImage> load_last_scene(const std::filesystem::path& scene_dir, const state::Log& log);

}  // namespace glint
