// What a visitor screen shows, decided by the kiosk (kiosk.hpp) and drawn by the screens
// (screens.hpp) over the 3D frame: the kiosk knows nothing of fonts, the screens nothing of
// capture or tracking. Strings are keys into the strings resource (strings.hpp), never text.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace glint::render {
struct ShadingMaps;
}

namespace glint::ui {

enum class KioskState : std::uint8_t { Attract, Capture, Processing, Ar };
// The button's lamp: blinking in ATTRACT (press me), on in AR (press for another material), off
// while the visitor scans and waits; the maintenance menu's lamp test sets it by hand.
enum class LampMode : std::uint8_t { Off, On, Blink };
// "ATTRACT", "CAPTURE", "PROCESSING", "AR" (summary.json, STATUS=, the journal).
const char* kiosk_state_name(KioskState state);

struct CaptureView {
    // Where to turn: the target's direction in the camera frame (OpenCV: +X right, +Y down, +Z
    // forward, unit) and the angle to it; on_target when within a few degrees.
    double target_x = 0, target_y = 0, target_z = 1;
    double turn_deg = 0;
    bool on_target = false;
    bool too_fast = false;            // "slower"
    std::string exposure = "ok";      // "ok", "too_bright", "too_dark", "bracketing"
    double progress = 0;              // 0..1
    double time_left_s = 0;
    // The minimap: coverage of the sphere, an equirect of minimap_width x minimap_height cells
    // (rows top first, 0 = unseen, 255 = well covered), and where the camera looks (world
    // direction, docs/conventions.md: +Y up, -Z at the map's centre).
    int minimap_width = 0, minimap_height = 0;
    std::vector<std::uint8_t> minimap;
    double view_x = 0, view_y = 0, view_z = -1;
    // The next target's world direction, marked on the minimap (0, 0, 0: not marked).
    double next_x = 0, next_y = 0, next_z = 0;
};

struct ProcessingView {
    double progress = 0;      // 0..1 over the whole PROCESSING state
    double time_left_s = 0;
    std::string step;         // key: "processing.adjusting", "processing.convolving", ...
};

struct ArView {
    std::string material;     // key of the material shown: "material.matte", ...
    bool tracked = false;     // the board is seen in this frame
    bool bridged = false;     // held by the orientation sensor through a dropout
    double visibility = 0;    // 1 seen, fading to 0 through a dropout
};

// The devices as the kiosk sees them, for the maintenance menu's status page.
struct DeviceView {
    double camera_fps = 0;       // frames in the last second
    double exposure_s = 0, gain = 0;  // of the newest frame
    double sensor_rate_hz = 0;   // orientation samples in the last second
    unsigned long long camera_restarts = 0;
    std::string sensor_health;   // "Streaming", "no orientation (Disconnected: ...)"
    std::string camera_error;    // the camera's last error ("" = none)
    std::string display_mode;    // gl::Display::describe()
    std::string gl_renderer;     // GL_RENDERER
    bool button_pressed = false; // the visitor's button, as its last event left it
    bool key_switch_on = false;  // the technician's key switch (GPIO)
    LampMode lamp = LampMode::Off;
    // The last scan's check of the camera-sensor calibration (capture::calibration_check_text),
    // "n/a" before.
    std::string alignment_check = "n/a";
    bool alignment_stale = false;
};

struct ScreenModel {
    KioskState state = KioskState::Attract;
    double t_in_state_s = 0;
    double t_s = 0;                 // since the program started
    CaptureView capture;
    ProcessingView processing;
    ArView ar;
    std::string message;            // key of a friendly message shown over any state ("" = none)
    bool degraded = false;          // the display fell back (shown small, for the technician)
    bool sensor_lost = false;       // "sensor lost, please wait"
    bool camera_lost = false;       // "camera restarting, please wait"
    DeviceView devices;
    // The maps the object is lit with now, for the menu's export (null before a room is lit; the
    // kiosk loop's own, valid for the frame).
    const render::ShadingMaps* shading_maps = nullptr;
};

}  // namespace glint::ui
