// SIGHUP reload (appliance/ui/config_reload.hpp): live keys applied, device keys waiting for a
// restart, an invalid file keeping the running configuration.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include "appliance/ui/config_keys.hpp"
#include "appliance/ui/config_reload.hpp"

namespace fs = std::filesystem;
using namespace glint::ui;
using Strings = std::vector<std::string>;

namespace {

class TempDir {
public:
    TempDir() {
        char tmpl[] = "/tmp/glint-reload-XXXXXX";
        path_ = ::mkdtemp(tmpl);
    }
    ~TempDir() { fs::remove_all(path_); }
    const fs::path& path() const { return path_; }

private:
    fs::path path_;
};

void write(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::trunc) << text; }

}  // namespace

TEST(ConfigReload, LiveKeysApplyDeviceKeysWaitForARestart) {
    TempDir dir;
    const fs::path file = dir.path() / "glint.toml";
    write(file, "[display]\nkind = \"kms\"\n[timeouts]\nar_idle_s = 45\n");
    ConfigReloader reloader(load_config(file));

    write(file, "[display]\nkind = \"headless\"\n[timeouts]\nar_idle_s = 90\n[frame]\nbudget_ms = 40\n");
    const ReloadReport r = reloader.reload();
    ASSERT_TRUE(r.ok) << r.error;
    EXPECT_EQ(r.applied_keys, (Strings{"frame.budget_ms", "timeouts.ar_idle_s"}));
    EXPECT_EQ(r.restart_keys, (Strings{"display.kind"}));
    EXPECT_EQ(r.changed_sections, (Strings{"display", "frame", "timeouts"}));
    EXPECT_EQ(r.live_sections, (Strings{"frame", "timeouts"}));
    EXPECT_EQ(r.restart_sections, (Strings{"display"}));
    EXPECT_TRUE(r.needs_restart());
    EXPECT_EQ(r.summary(), "config reloaded: applied frame.budget_ms, timeouts.ar_idle_s; restart needed for display.kind");
    // In effect: the new timeout and budget, the display it runs on.
    EXPECT_DOUBLE_EQ(reloader.current().timeouts.ar_idle_s, 90);
    EXPECT_DOUBLE_EQ(reloader.current().frame.budget_ms, 40);
    EXPECT_EQ(reloader.current().display.kind, "kms");

    // Reloading the same file again: the live keys are in effect, the display still waits.
    const ReloadReport again = reloader.reload();
    EXPECT_EQ(again.applied_keys, Strings{});
    EXPECT_EQ(again.restart_keys, (Strings{"display.kind"}));
}

TEST(ConfigReload, AnInvalidFileKeepsTheRunningConfiguration) {
    TempDir dir;
    const fs::path file = dir.path() / "glint.toml";
    write(file, "[timeouts]\nar_idle_s = 30\n");
    ConfigReloader reloader(load_config(file));
    write(file, "[timeouts]\nar_idle_s = 60\ncapture_s = -1\n");
    const ReloadReport r = reloader.reload();
    EXPECT_FALSE(r.ok);
    EXPECT_EQ(r.error, file.string() + ":3: key 'timeouts.capture_s': -1.0 is out of range (0.0, 86400.0]");
    EXPECT_EQ(r.summary(), "config reload failed, keeping the running configuration: " + r.error);
    EXPECT_FALSE(r.changed());
    EXPECT_DOUBLE_EQ(reloader.current().timeouts.ar_idle_s, 30);  // not half-applied
    EXPECT_EQ(reloader.current().file, file);

    fs::remove(file);
    const ReloadReport gone = reloader.reload();
    EXPECT_FALSE(gone.ok);
    EXPECT_EQ(gone.error, file.string() + ": cannot open: No such file or directory");
    // The file back, valid: the reload takes it.
    write(file, "[timeouts]\nar_idle_s = 60\n");
    EXPECT_TRUE(reloader.reload().ok);
    EXPECT_DOUBLE_EQ(reloader.current().timeouts.ar_idle_s, 60);
}

TEST(ConfigReload, NothingChanged) {
    TempDir dir;
    const fs::path file = dir.path() / "glint.toml";
    write(file, "[capture]\nmax_scan_s = 90\n");
    ConfigReloader reloader(load_config(file));
    const ReloadReport r = reloader.reload();
    EXPECT_TRUE(r.ok);
    EXPECT_FALSE(r.changed());
    EXPECT_EQ(r.summary(), "config reloaded, nothing changed");
}

TEST(ConfigReload, ArIsReadOnceMaterialsAndModelAlike) {
    // The materials' lobes are the maps PROCESSING makes; the kiosk does not rebuild them on SIGHUP.
    Config running = default_config();
    Config loaded = running;
    loaded.ar.materials = {"mirror"};
    loaded.ar.model = "sphere";
    ReloadReport r;
    const Config merged = merge_reload(running, loaded, r);
    EXPECT_TRUE(r.applied_keys.empty());
    EXPECT_EQ(r.restart_keys, (Strings{"ar.model", "ar.materials"}));
    EXPECT_EQ(r.restart_sections, (Strings{"ar"}));
    EXPECT_EQ(merged.ar.materials, running.ar.materials);
    EXPECT_EQ(merged.ar.model, "teapot");
}

// Which keys are live is decided in config.cpp's table; this is the rule it must follow
// (docs/service.md), written out independently.
TEST(ConfigReload, LivenessFollowsTheRule) {
    // What the kiosk loop applies on SIGHUP (kiosk_loop.cpp): budgets, timeouts, capture and
    // convolution settings; everything else waits for a restart.
    const std::set<std::string> live_sections = {"frame", "capture", "convolution", "timeouts"};
    for (const auto& k : config_keys()) EXPECT_EQ(k.live, live_sections.count(k.section) == 1) << k.name();
}
