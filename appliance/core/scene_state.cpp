// The kiosk's last scene as a state item (scene_state.hpp).
#include "appliance/core/scene_state.hpp"

#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"

namespace glint {
namespace fs = std::filesystem;

namespace {

fs::path staging_dir(const fs::path& scene_dir) {
    return scene_dir.parent_path() / ("." + scene_dir.filename().string() + ".capture");
}

state::LoadPolicy scene_policy() {
    state::LoadPolicy p;
    p.files = {kSceneEnv, kSceneCoverage};
    // An older build's plain directory has no checksums: it could be torn, and the scene is only
    // what ATTRACT shows, so it is set aside rather than trusted.
    p.unverified = state::Unverified::SetAside;
    p.check = [](const fs::path& item) {
        (void)load_exr(item / kSceneEnv);
        (void)load_exr(item / kSceneCoverage);
    };
    return p;
}

}  // namespace

fs::path scene_capture_path(const fs::path& scene_dir, bool replayed) {
    if (replayed) return scene_dir / kSceneEnv;
    const fs::path dir = staging_dir(scene_dir);
    std::error_code ec;
    // A capture cut short (a crash, a power cut) left its files and temporaries: a new one starts
    // from nothing.
    fs::remove_all(dir, ec);
    fs::create_directories(dir, ec);
    if (ec) throw RuntimeError(dir.string() + ": cannot create the capture's staging directory: " + ec.message());
    return dir / kSceneEnv;
}

HdrImage take_captured_scene(const fs::path& scene_dir, bool replayed, const state::Log& log) {
    const fs::path env_path = replayed ? scene_dir / kSceneEnv : staging_dir(scene_dir) / kSceneEnv;
    HdrImage env = load_exr(env_path).image;
    if (replayed) return env;
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
    const state::LoadedItem item = state::load_item(scene_dir.parent_path(), scene_dir.filename().string(), scene_policy(), log);
    if (!item.path) return std::nullopt;
    return *item.path / kSceneEnv;
}

std::optional<HdrImage> load_last_scene(const fs::path& scene_dir, const state::Log& log) {
    const std::optional<fs::path> env = last_scene_env(scene_dir, log);
    if (!env) return std::nullopt;
    try {
        return load_exr(*env).image;
    } catch (const std::exception& e) {
        // Verified a moment ago: only a disk failing under us gets here.
        if (log) log(std::string("state: the last scene could not be read: ") + e.what());
        return std::nullopt;
    }
}

}  // namespace glint
