// The kiosk's last scene as a state item (scene_state.hpp).
#include "appliance/core/scene_state.hpp"

#include <unistd.h>

#include <chrono>
#include <cmath>

#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"

namespace glint {
namespace fs = std::filesystem;

namespace {

fs::path staging_dir(const fs::path& scene_dir) {
    return scene_dir.parent_path() / ("." + scene_dir.filename().string() + ".capture");
}

// Where the capture writes when the state directory cannot take it (read-only): the visitor still
// gets the map; its commit then fails, is logged and shown (take_captured_scene).
fs::path fallback_dir() { return fs::temp_directory_path() / ("glint-scene-capture-" + std::to_string(::geteuid())); }

bool fresh_directory(const fs::path& dir) {
    std::error_code ec;
    // A capture cut short (a crash, a power cut) left its files and temporaries: a new one starts
    // from nothing.
    fs::remove_all(dir, ec);
    fs::create_directories(dir, ec);
    return !ec && ::access(dir.c_str(), W_OK) == 0;
}

// Loads the map (kept for the caller) and the coverage: the scene must parse to be used.
state::LoadPolicy scene_policy(std::optional<HdrImage>& env) {
    state::LoadPolicy p;
    p.files = {kSceneEnv, kSceneCoverage};
    // An older build's plain directory has no checksums: it could be torn, and the scene is only
    // what ATTRACT shows, so it is set aside rather than trusted.
    p.unverified = state::Unverified::SetAside;
    p.check = [&env](const fs::path& item) {
        env = load_exr(item / kSceneEnv).image;
        (void)load_exr(item / kSceneCoverage);
    };
    return p;
}

}  // namespace

fs::path scene_capture_path(const fs::path& scene_dir, bool replayed) {
    if (replayed) return scene_dir / kSceneEnv;
    // Never throws: it is called from the frame loop when a visitor starts a scan.
    const fs::path dir = staging_dir(scene_dir);
    if (fresh_directory(dir)) return dir / kSceneEnv;
    if (fresh_directory(fallback_dir())) return fallback_dir() / kSceneEnv;
    return dir / kSceneEnv;  // the capture's own save will fail and say why
}

HdrImage take_captured_scene(const fs::path& scene_dir, bool replayed, const state::Log& log) {
    if (replayed) return load_exr(scene_dir / kSceneEnv).image;
    std::error_code ec;
    fs::path env_path = staging_dir(scene_dir) / kSceneEnv;
    if (!fs::exists(env_path, ec) && fs::exists(fallback_dir() / kSceneEnv, ec)) env_path = fallback_dir() / kSceneEnv;
    HdrImage env = load_exr(env_path).image;
    const fs::path coverage = env_path.parent_path() / kSceneCoverage;
    try {
        state::save_item(scene_dir.parent_path(), scene_dir.filename().string(),
                         {state::moved_file(kSceneEnv, env_path), state::moved_file(kSceneCoverage, coverage)});
    } catch (const state::SaveError& e) {
        if (log) log(std::string("state: the scene was not saved (the last saved one stays): ") + e.what());
    }
    return env;
}

std::optional<fs::path> last_scene_env(const fs::path& scene_dir, const state::Log& log) {
    std::optional<HdrImage> env;
    const state::LoadedItem item = state::load_item(scene_dir.parent_path(), scene_dir.filename().string(), scene_policy(env), log);
    if (!item.path) return std::nullopt;
    return *item.path / kSceneEnv;
}

std::optional<HdrImage> load_last_scene(const fs::path& scene_dir, const state::Log& log) {
    const auto started = std::chrono::steady_clock::now();
    std::optional<HdrImage> env;
    const state::LoadedItem item = state::load_item(scene_dir.parent_path(), scene_dir.filename().string(), scene_policy(env), log);
    if (!item.path) return std::nullopt;
    if (log) {
        std::error_code ec;
        log("state: " + scene_dir.string() + ": the last scene (" + fs::canonical(scene_dir, ec).filename().string() + ", " +
            std::to_string(env->width()) + "x" + std::to_string(env->height()) + ") verified and loaded in " +
            std::to_string(std::lround(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - started).count())) +
            " ms");
    }
    return env;
}

}  // namespace glint
