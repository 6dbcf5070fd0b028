#include "appliance/app/kiosk_overlay.hpp"

#include <memory>

#include "appliance/app/scene_export.hpp"
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
        layer.begin_frame(dt_s, keys);
        ui::draw_visitor_screen(model, context.strings, width, height);
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
            if (context.log_tail) status.log_lines = context.log_tail->lines();
            status.cpu_temperature = ui::temperature_text(ui::cpu_temperature_c());
            status.free_disk = ui::bytes_text(ui::free_disk_bytes(context.config.state.dir));
            status.uptime = ui::duration_text(ui::uptime_s());
            status.settings = applied_settings.value_or(ui::MenuSettings{context.config.capture, context.config.convolution});
            std::error_code ec;
            if (std::filesystem::is_directory(context.config.state.export_dir, ec))
                status.export_targets = {context.config.state.export_dir + " (" +
                                         ui::bytes_text(ui::free_disk_bytes(context.config.state.export_dir)) + " free)"};
            status.export_result = export_result;
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
                        export_result = export_scene(a.export_items, {context.maps_dir, context.frames_dir, context.sessions_dir},
                                                     context.config.state.export_dir, utc_stamp())
                                            .summary();
                    } catch (const std::exception& e) {
                        export_result = e.what();
                    }
                    context.log("maintenance menu: " + export_result);
                } else if (a.kind != ui::MenuAction::Kind::Close)
                    context.log(std::string("maintenance menu: ") + ui::menu_action_name(a.kind) + " is not built yet");
            }
        }
        layer.end_frame();
        return menu.is_open();
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
