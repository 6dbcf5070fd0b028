// What `glint run` and `glint replay` draw over the kiosk's frames: the visitor screens, and the
// maintenance menu (docs/screens.md) opened by the configured key chord and the PIN, or by the
// key switch. The menu's actions are carried out here (journalled on stderr): a restart exits
// with 0 so that systemd starts the appliance again; an export copies the scene to the export
// directory (scene_export.hpp); a calibration wizard runs on the kiosk's input
// (calibration_wizard.hpp) and Apply saves its result, then restarts the kiosk to use it; the rest
// are reported as not built.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "appliance/app/calibration_wizard.hpp"
#include "appliance/app/log_tail.hpp"
#include "appliance/ui/config.hpp"
#include "appliance/ui/kiosk_loop.hpp"
#include "appliance/ui/maintenance_menu.hpp"
#include "appliance/ui/strings.hpp"

namespace glint::app {

struct OverlayContext {
    ui::Config config;
    ui::Strings strings;
    std::function<void(const std::string&)> log;  // the journal
    std::shared_ptr<const LogTail> log_tail;      // what the menu's log page shows (null: nothing)
    // Ends the kiosk loop (a restart requested from the menu).
    std::function<void()> request_restart;
    // The lamp test: a mode to hold until nullopt (the menu closed); null when there is no lamp.
    std::function<void(std::optional<ui::LampMode>)> set_lamp_test;
    // The settings page's Apply: applies and keeps them; returns the line to journal ("" = none
    // wired: the menu says so).
    std::function<std::string(const ui::MenuSettings&)> apply_settings;
    // What the menu's export copies (docs/kiosk.md), to config.state.export_dir.
    std::filesystem::path maps_dir, frames_dir, sessions_dir;
    // The calibration wizards (null: the page's Start says they are not available), fed the
    // kiosk's input by KioskOptions::observe_input; Apply saves the result into calibration_file.
    std::shared_ptr<CalibrationWizard> wizard;
    std::filesystem::path calibration_file;
    // The exposure a wizard needs (nullopt: the camera's own again); null: a replay's recorded exposures.
    std::function<void(std::optional<capture::ExposureRequest>)> set_exposure;
};

// The factory KioskOptions::make_overlay wants.
std::function<ui::KioskOptions::Overlay(int, int)> make_kiosk_overlay(OverlayContext context);

}  // namespace glint::app
