// The capture and convolution settings a technician applies in the maintenance menu (docs/kiosk.md,
// "Settings from the menu"): applied at once (they are live keys, like a SIGHUP reload) and kept
// in the state directory as the item `settings.toml` (core/state_store.hpp: checksummed, never
// torn), which overrides glint.toml's [capture] and [convolution] at every start and reload. The
// config file itself is never rewritten: it is the integrator's, with its comments.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "appliance/core/state_store.hpp"
#include "appliance/ui/config.hpp"
#include "appliance/ui/maintenance_menu.hpp"

namespace glint::app {

inline constexpr const char* kMenuSettingsItem = "settings.toml";

// The settings as the TOML the item holds (a valid glint.toml with only these keys).
std::string menu_settings_toml(const ui::MenuSettings& settings);
// Saves the item; throws state::SaveError naming the file and the system's reason.
void save_menu_settings(const std::filesystem::path& state_dir, const ui::MenuSettings& settings);
// The saved settings, verified and parsed with the config's own rules; nullopt when none were
// saved or the item is faulty (then set aside into corrupt/ and logged by the store).
std::optional<ui::MenuSettings> load_menu_settings(const std::filesystem::path& state_dir, const state::Log& log);
// Puts `settings` over `config`.
void apply_menu_settings(ui::Config& config, const ui::MenuSettings& settings);

}  // namespace glint::app
