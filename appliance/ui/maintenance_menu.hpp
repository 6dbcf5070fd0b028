// The technician's maintenance menu (docs/screens.md, "Maintenance menu"): ImGui windows over the
// kiosk's frame, driven by the keyboard. It does no I/O and checks no PIN itself: the kiosk
// fills a MaintenanceStatus each frame, gives a PIN check (pin_check_for(PinLock)), and carries out
// the MenuActions draw() returns (and journals them).
//
// Pages: the PIN entry, then Status, Calibrations, Capture & convolution settings, Log, Export,
// Buttons & lamp, Test pattern, Restart. F1..F8 choose a page, Prior/Next (Page Up/Down) step
// through them; inside a page the arrows move between buttons and space presses one; Escape
// closes the menu (from the test pattern: back to Status).
#pragma once

#include <algorithm>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "appliance/gl/display.hpp"
#include "appliance/ui/config.hpp"
#include "appliance/ui/pin_lock.hpp"
#include "appliance/ui/screen_model.hpp"
#include "appliance/ui/strings.hpp"

namespace glint::ui {

// What the PIN check answered, with what the PIN page shows.
struct PinAnswer {
    enum class Kind : std::uint8_t {
        Ok,        // the menu opens
        Wrong,     // attempts_left remain before the lock-out
        Locked,    // for locked_s more
        Disabled,  // no PIN configured: only the key switch opens the menu
    } kind = Kind::Wrong;
    int attempts_left = 0;
    double locked_s = 0;
};
using PinCheck = std::function<PinAnswer(const std::string& pin)>;

// The menu's check from the kiosk's PinLock (pin_lock.hpp, which journals every attempt):
// try_pin's result with the attempts left (of the config's max_attempts) and the lock-out's
// remaining time. `lock` must outlive the check.
inline PinCheck pin_check_for(PinLock& lock, int max_attempts) {
    return [&lock, max_attempts](const std::string& pin) {
        PinAnswer answer;
        switch (lock.try_pin(pin)) {
            case PinResult::Accepted: answer.kind = PinAnswer::Kind::Ok; break;
            case PinResult::Rejected:
                answer.kind = PinAnswer::Kind::Wrong;
                answer.attempts_left = std::max(0, max_attempts - lock.failures());
                break;
            case PinResult::LockedOut:
                answer.kind = PinAnswer::Kind::Locked;
                answer.locked_s = lock.remaining_s();
                break;
            case PinResult::Disabled: answer.kind = PinAnswer::Kind::Disabled; break;
        }
        return answer;
    };
}

enum class CalibrationKind : std::uint8_t { CameraIntrinsics, Response, Vignetting, Alignment, TimeOffset };
inline constexpr int kCalibrationKinds = 5;

// The capture and convolution values the settings page edits: copies of the config's sections.
struct MenuSettings {
    CaptureSection capture;
    ConvolutionSection convolution;
    bool operator==(const MenuSettings& o) const {
        return capture.map_width == o.capture.map_width && capture.map_height == o.capture.map_height &&
               capture.target_coverage == o.capture.target_coverage && capture.max_scan_s == o.capture.max_scan_s &&
               convolution.tolerance == o.convolution.tolerance;
    }
};

// LampMode: screen_model.hpp (the kiosk drives the lamp too).

// Everything the pages show, filled by the kiosk (texts ready to show, except where noted).
struct MaintenanceStatus {
    // Status
    std::string kiosk_state;          // "ATTRACT", ...
    std::string sensor_health;        // "ok", "no samples for 2.1 s", ...
    bool sensor_ok = false;
    double sensor_rate_hz = 0;
    double camera_fps = 0;
    double exposure_s = 0;
    double gain = 0;
    std::string display_mode;         // gl::Display::describe()
    bool display_degraded = false;
    std::string gl_renderer;
    std::string cpu_temperature = "n/a";  // system_status.hpp's texts
    std::string free_disk = "n/a";
    std::string uptime = "n/a";
    std::string state_store = "ok";  // the state directory: "ok", the last failed save, faulty files set aside
    bool state_store_ok = true;      // false: the last save failed (shown in red)
    bool state_store_warn = false;   // faulty files were set aside (shown in amber)
    // The last scan's check of the camera-sensor calibration (capture::calibration_check_text
    // in capture_pipeline.hpp); stale: shown in amber.
    std::string alignment_check = "n/a";
    bool alignment_stale = false;
    // Calibrations: the wizard running (if any), its step and the last result.
    bool calibration_running = false;
    CalibrationKind calibration = CalibrationKind::CameraIntrinsics;
    std::string calibration_step;     // "Show the board at the top left corner (3 of 12)"
    std::string calibration_result;   // "RMS reprojection error 0.31 px"
    double calibration_progress = 0;  // 0..1 of what the step collects
    bool calibration_can_apply = false;  // a result Apply would keep
    unsigned calibration_preview_texture = 0;  // an RGBA GL texture of the live camera image (0: none)
    int calibration_preview_width = 0, calibration_preview_height = 0;
    // Settings in force (the page edits a copy)
    MenuSettings settings;
    // Log tail, oldest first
    std::vector<std::string> log_lines;
    // Export
    std::vector<std::string> export_targets;  // mounted places, e.g. "/media/usb (USB stick, 14.2 GB free)"
    std::string export_result;                 // "wrote 5 files (82 MB) to /media/usb/glint-20261203"
    // Buttons & lamp
    bool button_pressed = false;
    bool key_switch_on = false;
    LampMode lamp = LampMode::Off;
};

// What the technician asked for.
struct MenuAction {
    enum class Kind : std::uint8_t {
        Close,              // the menu closed (Escape)
        StartCalibration,   // calibration
        CancelCalibration,
        ApplyCalibration,   // keep the wizard's result
        ApplySettings,      // settings
        Export,             // export_target, export_items
        Lamp,               // lamp
        RestartKiosk,       // confirmed by a second press
        RebootAppliance,    // confirmed by a second press
    } kind = Kind::Close;
    CalibrationKind calibration = CalibrationKind::CameraIntrinsics;
    MenuSettings settings;
    int export_target = -1;  // index into MaintenanceStatus::export_targets
    // What to export (bits of ExportItem).
    std::uint8_t export_items = 0;
    LampMode lamp = LampMode::Off;
};
enum ExportItem : std::uint8_t { kExportEnvMap = 1, kExportMaps = 2, kExportScreenshots = 4, kExportSessions = 8 };

const char* menu_action_name(MenuAction::Kind kind);  // "close", "start-calibration", ... (the journal)

class MaintenanceMenu {
public:
    enum class Page : std::uint8_t { Pin, Status, Calibrations, Settings, Log, Export, Buttons, Pattern, Restart };

    explicit MaintenanceMenu(PinCheck check);

    // Opens at the PIN page (keyboard chord), or straight at Status when `unlocked` (the key switch).
    void open(bool unlocked = false);
    void close();
    bool is_open() const { return open_; }
    Page page() const { return page_; }
    // Any page but Pin once unlocked (the kiosk, tests); ignored while locked.
    void set_page(Page page);

    // Draws the open menu inside an ImGui frame (ImGuiLayer) and returns the actions of this
    // frame. `keys`: the same events the layer's begin_frame got. Nothing when closed.
    std::vector<MenuAction> draw(const MaintenanceStatus& status, const std::vector<gl::InputEvent>& keys,
                                 const Strings& strings, int width, int height);

private:
    void handle_keys(const std::vector<gl::InputEvent>& keys, std::vector<MenuAction>& actions);
    void submit_pin();
    void draw_pin(const Strings& s, int width, int height);
    void draw_pages(const MaintenanceStatus& status, const Strings& s, int width, int height, std::vector<MenuAction>& actions);
    void draw_status(const MaintenanceStatus& status, const Strings& s);
    void draw_calibrations(const MaintenanceStatus& status, const Strings& s, std::vector<MenuAction>& actions);
    void draw_settings(const MaintenanceStatus& status, const Strings& s, std::vector<MenuAction>& actions);
    void draw_log(const MaintenanceStatus& status, const Strings& s);
    void draw_export(const MaintenanceStatus& status, const Strings& s, std::vector<MenuAction>& actions);
    void draw_buttons(const MaintenanceStatus& status, const Strings& s, std::vector<MenuAction>& actions);
    void draw_restart(const Strings& s, std::vector<MenuAction>& actions);

    PinCheck check_;
    bool open_ = false;
    bool unlocked_ = false;
    Page page_ = Page::Pin;
    bool page_changed_ = false;  // the page window takes the keyboard focus
    bool focus_pending_ = false; // ... and its first button the nav focus, once it is drawn
    std::string pin_;
    std::string pin_message_;
    bool pin_message_is_error_ = false;
    MenuSettings edit_;
    bool editing_ = false;       // edit_ holds the technician's changes (not overwritten by the status)
    int export_target_ = 0;
    std::uint8_t export_items_ = kExportEnvMap | kExportMaps;
    MenuAction::Kind armed_ = MenuAction::Kind::Close;  // Restart/Reboot pressed once
    double armed_at_ = -1e9;
    bool apply_shown_ = false;   // the calibration's Apply button was drawn last frame
};

// The keyboard chord that asks for the PIN ([maintenance] chord, e.g. "ctrl+alt+m": modifiers
// ctrl, alt, shift, super and one key a-z, 0-9 or f1-f12, the grammar config.cpp checks). Fed
// every frame's events, it follows the modifiers held and says when the chord's key went down
// with all of them held (more held do not matter). "" never fires.
class MenuChord {
public:
    // Throws InputError naming the chord when it is not of that grammar.
    explicit MenuChord(const std::string& chord);
    // True when this batch of events completed the chord.
    bool feed(const std::vector<gl::InputEvent>& events);

private:
    enum Modifier : std::uint8_t { kCtrl = 1, kAlt = 2, kShift = 4, kSuper = 8 };
    std::uint8_t wanted_ = 0, held_left_ = 0, held_right_ = 0;
    std::string key_;  // the X11 keysym, lower case ("m", "f1" for "F1")
};

// The display test pattern over the whole frame: eight colour bars (white, yellow, cyan, green,
// magenta, red, blue, black) in the top half, a grey ramp from black to white, a 16-step grey
// scale, and a 1-pixel white grid every 32 pixels on black with a 1-pixel frame at the edges.
void draw_test_pattern(int width, int height);

}  // namespace glint::ui
