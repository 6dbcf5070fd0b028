// The maintenance menu's settings kept in the state directory (appliance/app/menu_settings.hpp).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <vector>

#include "appliance/app/menu_settings.hpp"

namespace glint::app {
namespace {

namespace fs = std::filesystem;

fs::path fresh_dir(const std::string& name) {
    const fs::path dir = fs::temp_directory_path() / ("glint_menu_settings_" + name);
    fs::remove_all(dir);
    return dir;
}

ui::MenuSettings example() {
    ui::MenuSettings s;
    s.capture.map_width = 2048;
    s.capture.map_height = 1024;
    s.capture.target_coverage = 0.9;
    s.capture.max_scan_s = 75.5;
    s.convolution.tolerance = 0.02;
    return s;
}

TEST(MenuSettings, KeptAndReadBackExactlyAndPutOverTheConfig) {
    const fs::path dir = fresh_dir("roundtrip");
    std::vector<std::string> log;
    EXPECT_FALSE(load_menu_settings(dir, [&](const std::string& l) { log.push_back(l); }));  // none saved yet
    save_menu_settings(dir, example());
    const std::optional<ui::MenuSettings> back = load_menu_settings(dir, [&](const std::string& l) { log.push_back(l); });
    ASSERT_TRUE(back);
    EXPECT_TRUE(*back == example());
    ui::Config config = ui::default_config();
    const std::string model = config.ar.model;
    apply_menu_settings(config, *back);
    EXPECT_EQ(config.capture.map_width, 2048);
    EXPECT_DOUBLE_EQ(config.convolution.tolerance, 0.02);
    EXPECT_EQ(config.ar.model, model);  // nothing else changes
    // A newer Apply replaces it.
    ui::MenuSettings newer = example();
    newer.capture.max_scan_s = 60;
    save_menu_settings(dir, newer);
    EXPECT_DOUBLE_EQ(load_menu_settings(dir, {})->capture.max_scan_s, 60);
}

TEST(MenuSettings, ADamagedOrInvalidItemIsSetAsideAndTheConfigsOwnKeysHold) {
    const fs::path dir = fresh_dir("damaged");
    save_menu_settings(dir, example());
    // A byte changed behind the store's back: the checksum no longer matches.
    const fs::path file = fs::canonical(dir / kMenuSettingsItem);
    {
        std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
        f.seekp(20);
        f.put('#');
    }
    std::vector<std::string> log;
    EXPECT_FALSE(load_menu_settings(dir, [&](const std::string& l) { log.push_back(l); }));
    EXPECT_FALSE(log.empty());
    EXPECT_TRUE(fs::is_directory(dir / "corrupt"));
    EXPECT_FALSE(fs::exists(dir / kMenuSettingsItem));

    // Values the config's rules refuse (a map that is not 2:1) are no settings either.
    ui::MenuSettings bad = example();
    bad.capture.map_height = 1000;
    save_menu_settings(dir, bad);
    log.clear();
    EXPECT_FALSE(load_menu_settings(dir, [&](const std::string& l) { log.push_back(l); }));
    EXPECT_FALSE(log.empty());
}

}  // namespace
}  // namespace glint::app
