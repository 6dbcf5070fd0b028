// Versions of the state items and the writer (state_versions.hpp).
#include "tests/faults/state_versions.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "appliance/capture/calibration_io.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/scene_state.hpp"
#include "appliance/core/state_store.hpp"
#include "appliance/ui/config.hpp"
#include "appliance/ui/pin_lock.hpp"

namespace glint::faults {
namespace fs = std::filesystem;

namespace {

std::string read_text(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

bool same_texels(const HdrImage& a, const HdrImage& b) {
    return a.width() == b.width() && a.height() == b.height() && a.data() == b.data();
}

ui::MaintenanceSection writer_policy() {
    ui::MaintenanceSection m;
    m.pin_hash = kFastPinHash;
    m.max_attempts = 1 << 30;  // never locks: the count is the version
    return m;
}

void say(int fd, const std::string& line) {
    const std::string text = line + "\n";
    // One write per line: a pipe takes up to PIPE_BUF bytes whole.
    if (fd >= 0 && ::write(fd, text.data(), text.size()) != ssize_t(text.size())) _exit(4);
}

}  // namespace

HdrImage scene_env(std::uint64_t v, int width, int height) {
    HdrImage img(width, height);
    const float fv = float(v);
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i)
            img.set(i, j, {fv + 0.25f * float(i), fv * 0.5f + float(j), float((v * 31 + std::uint64_t(i * 7 + j)) % 1024)});
    img.set(0, 0, {fv, fv, fv});
    return img;
}

HdrImage scene_coverage(std::uint64_t v, int width, int height) {
    HdrImage img(width, height);
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i) {
            const float c = float((v + std::uint64_t(i + j * width)) % 17);
            img.set(i, j, {c, c, float(v % 251)});
        }
    return img;
}

capture::CameraCalibration calibration_version(std::uint64_t v) {
    capture::CameraCalibration c;
    c.intrinsics.width = 640;
    c.intrinsics.height = 480;
    c.intrinsics.fx = c.intrinsics.fy = 500;
    c.intrinsics.cx = 319.5;
    c.intrinsics.cy = 239.5;
    c.time_offset_s = double(v);  // the version, exact in a double
    return c;
}

std::string settings_version(std::uint64_t v) {
    return "# the fault tests' settings, version " + std::to_string(v) + "\n[state]\ndir = \"/var/lib/glint/v" +
           std::to_string(v) + "\"\n";
}

std::string pin_lock_text(int failures) {
    return "glint-pin-lock 1\nboot " + std::string(kBootId) + "\nfailures " + std::to_string(failures) +
           "\nlocked_until_ns 0\n";
}

ItemVersions read_versions(const fs::path& state_dir, std::string& problems, const std::function<void(const std::string&)>& log) {
    ItemVersions r;
    const auto problem = [&](const std::string& what) { problems += what + "\n"; };
    const state::Log loader_log = [&](const std::string& line) {
        problem("loader: " + line);
        if (log) log(line);
    };

    // The scene, as the kiosk loads it after a restart.
    if (const std::optional<fs::path> env = last_scene_env(state_dir / kSceneItem, loader_log)) {
        const HdrImage e = load_exr(*env).image;
        const HdrImage c = load_exr(env->parent_path() / kSceneCoverage).image;
        const std::uint64_t v = std::uint64_t(e.at(0, 0).r);
        if (!same_texels(e, scene_env(v))) problem("scene: env.exr matches no version (texel 0 says " + std::to_string(v) + ")");
        else if (!same_texels(c, scene_coverage(v))) problem("scene: env.coverage.exr is not version " + std::to_string(v) + "'s (a mix)");
        else r.scene = v;
    }
    if (const std::optional<capture::CameraCalibration> cal = capture::load_state_calibration(state_dir, loader_log)) {
        const std::uint64_t v = std::uint64_t(cal->time_offset_s);
        if (read_text(state_dir / capture::kStateCalibrationName) != capture::calibration_to_json(calibration_version(v)))
            problem("calibration: calibration.json is not version " + std::to_string(v) + "'s text");
        else r.calibration = v;
    }
    {
        state::LoadPolicy policy;
        policy.files = {kSettingsItem};
        policy.check = [](const fs::path& file) { (void)ui::load_config(file); };
        const state::LoadedItem item = state::load_item(state_dir, kSettingsItem, policy, loader_log);
        if (item.path) {
            const std::string dir = ui::load_config(*item.path).state.dir;
            const std::uint64_t v = std::stoull(dir.substr(dir.rfind('v') + 1));
            if (read_text(*item.path) != settings_version(v)) problem("settings: not version " + std::to_string(v) + "'s text");
            else r.settings = v;
        }
    }
    {
        bool state_error = false;
        const fs::path file = state_dir / kPinLockItem;
        const bool existed = fs::exists(file);
        ui::PinLock lock(writer_policy(), file,
                         [&](const ui::PinEvent& e) {
                             if (e.kind == ui::PinEvent::Kind::StateError) {
                                 state_error = true;
                                 problem("pin lock: " + ui::describe(e));
                             }
                         },
                         ui::monotonic_now_ns, kBootId);
        if (existed && !state_error) {
            if (read_text(file) != pin_lock_text(lock.failures()))
                problem("pin lock: not the text of " + std::to_string(lock.failures()) + " failures");
            else r.pin = std::uint64_t(lock.failures());
        }
    }
    std::error_code ec;
    if (fs::exists(state_dir / state::kCorruptDir, ec)) problem("something was set aside into " + (state_dir / state::kCorruptDir).string());
    return r;
}

int run_writer(const fs::path& state_dir, int report_fd, long long rounds) {
    std::string problems;
    const ItemVersions on_disk = read_versions(state_dir, problems, {});
    if (!problems.empty()) {
        std::fprintf(stderr, "state writer: what it found on start:\n%s", problems.c_str());
        return 3;
    }
    std::uint64_t v = 1 + std::max({on_disk.scene.value_or(0), on_disk.calibration.value_or(0), on_disk.settings.value_or(0)});
    ui::PinLock lock(writer_policy(), state_dir / kPinLockItem, {}, ui::monotonic_now_ns, kBootId);
    say(report_fd, "ready");  // what follows is saves only: the test's kills start counting here
    std::string save_errors;
    const state::Log log = [&](const std::string& line) { save_errors += line + "\n"; };
    const fs::path scene_dir = state_dir / kSceneItem;
    for (long long k = 0; rounds <= 0 || k < rounds; ++k, ++v) {
        say(report_fd, "round " + std::to_string(v));
        // The scene as the kiosk saves it: the capture writes its coverage, then its map, into the
        // staging directory; the map is read back and both committed.
        const fs::path env_path = scene_capture_path(scene_dir, false);
        save_exr(env_path.parent_path() / kSceneCoverage, scene_coverage(v));
        save_exr(env_path, scene_env(v));
        (void)take_captured_scene(scene_dir, false, log);
        if (!save_errors.empty()) {
            std::fprintf(stderr, "state writer: %s", save_errors.c_str());
            return 3;
        }
        say(report_fd, "scene " + std::to_string(v));
        capture::save_state_calibration(state_dir, calibration_version(v));
        say(report_fd, "calibration " + std::to_string(v));
        state::save_item(state_dir, kSettingsItem, {state::text_file(kSettingsItem, settings_version(v))});
        say(report_fd, "settings " + std::to_string(v));
        if (lock.try_pin("0000") != ui::PinResult::Rejected) {
            std::fprintf(stderr, "state writer: the PIN lock did not reject a wrong PIN\n");
            return 3;
        }
        say(report_fd, "pin " + std::to_string(lock.failures()));
    }
    return 0;
}

}  // namespace glint::faults
