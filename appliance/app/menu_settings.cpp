#include "appliance/app/menu_settings.hpp"

#include <cstdio>

namespace glint::app {

std::string menu_settings_toml(const ui::MenuSettings& s) {
    char text[512];
    std::snprintf(text, sizeof text,
                  "# Written by the maintenance menu's settings page; overrides glint.toml's keys below\n"
                  "# (docs/kiosk.md, \"Settings from the menu\").\n"
                  "[capture]\nmap_width = %d\nmap_height = %d\ntarget_coverage = %.17g\nmax_scan_s = %.17g\n\n"
                  "[convolution]\ntolerance = %.17g\n",
                  s.capture.map_width, s.capture.map_height, s.capture.target_coverage, s.capture.max_scan_s,
                  s.convolution.tolerance);
    return text;
}

void save_menu_settings(const std::filesystem::path& state_dir, const ui::MenuSettings& settings) {
    state::save_item(state_dir, kMenuSettingsItem, {state::text_file(kMenuSettingsItem, menu_settings_toml(settings))});
}

std::optional<ui::MenuSettings> load_menu_settings(const std::filesystem::path& state_dir, const state::Log& log) {
    std::optional<ui::Config> parsed;
    state::LoadPolicy policy;
    policy.files = {kMenuSettingsItem};
    policy.check = [&](const std::filesystem::path& path) { parsed = ui::load_config(path); };
    const state::LoadedItem item = state::load_item(state_dir, kMenuSettingsItem, policy, log);
    if (!item.path || !parsed) return std::nullopt;
    return ui::MenuSettings{parsed->capture, parsed->convolution};
}

void apply_menu_settings(ui::Config& config, const ui::MenuSettings& settings) {
    config.capture = settings.capture;
    config.convolution = settings.convolution;
}

}  // namespace glint::app
