#include "appliance/app/kiosk_overlay.hpp"

#include <chrono>
#include <memory>

#include "appliance/app/scene_export.hpp"
#include "appliance/capture/calibration_io.hpp"
#include "appliance/core/state_store.hpp"
#include "appliance/ui/imgui_layer.hpp"
#include "appliance/ui/maintenance_menu.hpp"
#include "appliance/ui/pin_lock.hpp"
#include "appliance/ui/screens.hpp"
#include "appliance/ui/system_status.hpp"

namespace glint::app {

namespace {

struct OverlayState {
    OverlayContext context;
    ui::ImGuiLayer layer;
    ui::PinLock pin_lock;
    ui::MaintenanceMenu menu;
    ui::MenuChord chord;
    int width, height;
    std::string export_result;
    bool key_switch_on = false;
    std::optional<ui::MenuSettings> applied_settings;  // the settings page's last Apply
    std::optional<ui::LampMode> lamp_test;  // set by the menu's lamp test until the menu closes
    std::string wizard_note;                 // why a wizard did not start, or where Apply saved
    WizardPreview preview;                   // the wizard's latest preview ...
    std::uintptr_t preview_texture = 0;      // ... on the GPU (the layer's image "calibration")
    std::optional<capture::ExposureRequest> exposure_asked;

    OverlayState(OverlayContext c, int w, int h)
        : context(std::move(c)), layer(w, h),
          pin_lock(context.config.maintenance, std::filesystem::path(context.config.state.dir) / "pin-lock.json",
                   [this](const ui::PinEvent& e) { context.log(ui::describe(e)); }),
          menu(ui::pin_check_for(pin_lock, context.config.maintenance.max_attempts)),
          chord(context.config.maintenance.chord), width(w), height(h) {}

    bool draw(const ui::ScreenModel& model, double dt_s, const std::vector<gl::InputEvent>& keys) {
        // The key switch opens the menu without the PIN (the key is the credential) and closes it
        // when turned back; the lamp test's setting ends with the menu.
        if (model.devices.key_switch_on != key_switch_on) {
            key_switch_on = model.devices.key_switch_on;
            if (key_switch_on && !menu.is_open()) {
                menu.open(/*unlocked=*/true);
                context.log("maintenance menu: opened by the key switch");
            } else if (!key_switch_on && menu.is_open()) {
                menu.close();
                context.log("maintenance menu: closed by the key switch");
            }
        }
        if (!menu.is_open() && chord.feed(keys)) {
            menu.open();
            context.log("maintenance menu: opened by the key chord, asking for the PIN");
        }
        if (!menu.is_open() && lamp_test) {
            lamp_test.reset();
            if (context.set_lamp_test) context.set_lamp_test(std::nullopt);
        }
        if (context.wizard) {
            // A wizard lasts while the menu is open: a technician who walks away leaves no camera
            // in manual exposure.
            if (!menu.is_open()) context.wizard->cancel();
            // A visitor's scan (the big button works while the menu is open) takes the camera.
            if (model.state == ui::KioskState::Capture && context.wizard->view().running) {
                context.wizard->cancel();
                wizard_note = context.strings.get("menu.calib.busy");
            }
            const std::optional<capture::ExposureRequest> asked = context.wizard->exposure_request();
            const bool changed = asked.has_value() != exposure_asked.has_value() ||
                                 (asked && asked->exposure_s != exposure_asked->exposure_s);
            if (changed && context.set_exposure) context.set_exposure(asked);
            exposure_asked = asked;
            if (context.wizard->preview_since(preview))
                preview_texture = reinterpret_cast<std::uintptr_t>(
                    layer.image("calibration", preview.width, preview.height, preview.rgba.data()));
        }
        layer.begin_frame(dt_s, keys);
        // The visitor's texts are drawn over everything else they share the frame with: under
        // an open menu they would cover its pages, so the technician sees the menu alone.
        if (!menu.is_open()) ui::draw_visitor_screen(model, context.strings, width, height);
        if (menu.is_open()) {
            ui::MaintenanceStatus status;
            status.kiosk_state = ui::kiosk_state_name(model.state);
            status.display_degraded = model.degraded;
            status.sensor_ok = !model.sensor_lost;
            status.sensor_health = model.devices.sensor_health.empty() ? (model.sensor_lost ? "no orientation" : "ok")
                                                                         : model.devices.sensor_health;
            status.sensor_rate_hz = model.devices.sensor_rate_hz;
            status.camera_fps = model.devices.camera_fps;
            status.exposure_s = model.devices.exposure_s;
            status.gain = model.devices.gain;
            status.display_mode = model.devices.display_mode;
            status.gl_renderer = model.devices.gl_renderer;
            status.button_pressed = model.devices.button_pressed;
            status.key_switch_on = model.devices.key_switch_on;
            status.lamp = lamp_test.value_or(model.devices.lamp);
            status.alignment_check = model.devices.alignment_check;
            status.alignment_stale = model.devices.alignment_stale;
            if (context.log_tail) status.log_lines = context.log_tail->lines();
            status.cpu_temperature = ui::temperature_text(ui::cpu_temperature_c());
            status.free_disk = ui::bytes_text(ui::free_disk_bytes(context.config.state.dir));
            status.uptime = ui::duration_text(ui::uptime_s());
            // A failed save (disk full, read-only) stays on the page until a save succeeds.
            if (const std::optional<std::string> error = state::last_save_error()) {
                status.state_store = "last save failed: " + *error;
                status.state_store_ok = false;
            } else if (const std::size_t set_aside = corrupt_sets_now(); set_aside > 0) {
                status.state_store = "ok; " + std::to_string(set_aside) + " faulty item(s) set aside in " +
                                     (std::filesystem::path(context.config.state.dir) / state::kCorruptDir).string();
                status.state_store_warn = true;
            }
            status.settings = applied_settings.value_or(ui::MenuSettings{context.config.capture, context.config.convolution});
            std::error_code ec;
            if (std::filesystem::is_directory(context.config.state.export_dir, ec))
                status.export_targets = {context.config.state.export_dir + " (" +
                                         ui::bytes_text(ui::free_disk_bytes(context.config.state.export_dir)) + " free)"};
            status.export_result = export_result;
            if (context.wizard) {
                const WizardView w = context.wizard->view();
                status.calibration_running = w.running;
                status.calibration = w.kind;
                status.calibration_step = w.step;
                status.calibration_progress = w.progress;
                status.calibration_result = wizard_note.empty() ? w.result : wizard_note;
                status.calibration_can_apply = w.can_apply;
                if (preview_texture != 0 && (w.running || w.can_apply)) {
                    status.calibration_preview_texture = unsigned(preview_texture);
                    status.calibration_preview_width = preview.width;
                    status.calibration_preview_height = preview.height;
                }
            }
            for (const ui::MenuAction& a : menu.draw(status, keys, context.strings, width, height)) {
                context.log(std::string("maintenance menu: ") + ui::menu_action_name(a.kind));
                if (a.kind == ui::MenuAction::Kind::RestartKiosk && context.request_restart) {
                    context.request_restart();
                } else if (a.kind == ui::MenuAction::Kind::ApplySettings) {
                    if (context.apply_settings) {
                        context.log("maintenance menu: " + context.apply_settings(a.settings));
                        applied_settings = a.settings;
                    } else {
                        context.log("maintenance menu: settings cannot be applied in a replay");
                    }
                } else if (a.kind == ui::MenuAction::Kind::Lamp) {
                    lamp_test = a.lamp;
                    if (context.set_lamp_test) context.set_lamp_test(a.lamp);
                    else context.log("maintenance menu: no lamp to test (no GPIO)");
                } else if (a.kind == ui::MenuAction::Kind::Export) {
                    try {
                        export_result = export_scene(a.export_items, {context.maps_dir, context.frames_dir, context.sessions_dir, model.shading_maps},
                                                     context.config.state.export_dir, utc_stamp())
                                            .summary();
                    } catch (const std::exception& e) {
                        export_result = e.what();
                    }
                    context.log("maintenance menu: " + export_result);
                } else if (a.kind == ui::MenuAction::Kind::StartCalibration ||
                           a.kind == ui::MenuAction::Kind::CancelCalibration ||
                           a.kind == ui::MenuAction::Kind::ApplyCalibration) {
                    calibration_action(a, model.state);
                } else if (a.kind != ui::MenuAction::Kind::Close)
                    context.log(std::string("maintenance menu: ") + ui::menu_action_name(a.kind) + " is not built yet");
            }
        }
        layer.end_frame();
        return menu.is_open();
    }

    // The sets in <state>/corrupt/, listed at most every 2 s (not a directory listing a frame).
    std::size_t corrupt_sets_now() {
        const auto now = std::chrono::steady_clock::now();
        if (now - corrupt_listed_at > std::chrono::seconds(2)) {
            corrupt_count = state::corrupt_sets(context.config.state.dir);
            corrupt_listed_at = now;
        }
        return corrupt_count;
    }
    std::size_t corrupt_count = 0;
    std::chrono::steady_clock::time_point corrupt_listed_at{};

    void calibration_action(const ui::MenuAction& a, ui::KioskState state) {
        if (!context.wizard) {
            wizard_note = "no calibration wizard here";
            context.log("maintenance menu: " + wizard_note);
            return;
        }
        wizard_note.clear();
        if (a.kind == ui::MenuAction::Kind::CancelCalibration) {
            context.wizard->cancel();
        } else if (a.kind == ui::MenuAction::Kind::StartCalibration) {
            // A visitor's scan drives the camera's exposure and needs the frames: not both at once.
            if (state == ui::KioskState::Capture || state == ui::KioskState::Processing) {
                wizard_note = context.strings.get("menu.calib.busy");
                context.log("maintenance menu: calibration wizard not started: a visitor's scan is running");
                return;
            }
            context.wizard->start(a.calibration, utc_stamp());
        } else if (const std::optional<capture::CameraCalibration> result = context.wizard->result()) {
            try {
                capture::check_calibration_usable(*result, context.calibration_file.string());
                capture::save_calibration(context.calibration_file, *result);
                context.wizard->set_current(*result);
                wizard_note = "saved to " + context.calibration_file.string() +
                              (context.request_restart ? "; the kiosk restarts to use it" : "");
                context.log("maintenance menu: calibration " + wizard_note);
                if (context.request_restart) context.request_restart();
            } catch (const std::exception& e) {
                // The old file stays as it was (the state store writes a new version or nothing).
                wizard_note = std::string("not saved: ") + e.what();
                context.log("maintenance menu: calibration " + wizard_note);
            }
        }
    }
};

}  // namespace

std::function<ui::KioskOptions::Overlay(int, int)> make_kiosk_overlay(OverlayContext context) {
    return [context](int width, int height) -> ui::KioskOptions::Overlay {
        auto state = std::make_shared<OverlayState>(context, width, height);
        return [state](const ui::ScreenModel& model, double dt_s, const std::vector<gl::InputEvent>& keys) {
            return state->draw(model, dt_s, keys);
        };
    };
}

}  // namespace glint::app
