// The appliance's configuration (docs/kiosk.md, "Configuration"): one TOML file, every key with
// its default in the shipped example (config/glint.example.toml). load_config() parses and
// validates it: an unknown key, a wrong type or a value out of range is a ConfigError naming the
// file, the line and the key. Every field below is one key; the section is the struct's name.
#pragma once

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "appliance/core/errors.hpp"

namespace glint::ui {

// An unusable configuration. what(): "FILE:LINE: key 'section.key': what is wrong". It is bad
// input, so the commands exit with 2 (docs/architecture.md, "Commands"), which the unit's
// RestartPreventExitStatus=2 relies on: a broken file is not restarted in a loop.
class ConfigError : public InputError {
public:
    using InputError::InputError;
};

struct DisplaySection {          // [display]
    std::string kind = "auto";   // auto | kms | window | headless
    std::string card, connector, mode;  // kms: "" = found by enumeration / preferred mode
    std::string kms_api = "auto";       // kms: auto | atomic | legacy page flips
    int width = 1280, height = 720;     // window and headless
    bool fullscreen = true;             // window
    std::string vt = "auto";            // kms: the VT locked ("auto", "none", "/dev/ttyN"; docs/lockdown.md)
    bool vt_lock_switch = false;        // kms: VT_LOCKSWITCH too (needs CAP_SYS_TTY_CONFIG)
    std::string vt_switch = "refuse";   // kms: a switch away refused, or let go with card and keyboards
    std::string keyboard = "grab";      // kms: evdev keyboards: grab | shared | none
};

struct CameraSection {                // [camera]
    std::string source = "libcamera"; // a camera spec (capture/camera_factory.hpp)
    std::string calibration;          // camera calibration JSON ("" = <state>/calibration.json)
};

struct SensorSection {                      // [sensor]
    std::string source = "serial:/dev/glint-sensor";  // an orientation source spec (host/source_spec.hpp)
};

struct GpioSection {                  // [gpio]
    std::string chip = "gpiochip0";   // "" = no GPIO (keyboard only)
    int button_line = 17;             // the visitor's big button (active low)
    int key_switch_line = 27;         // the technician's key switch: opens the maintenance menu (-1: none)
    int lamp_line = 22;               // the button's lamp (-1: none)
    double debounce_ms = 20;
};

struct FrameSection {           // [frame]
    double budget_ms = 33.333;  // what one frame may take (30 Hz)
    double hard_cap_ms = 100;   // a frame over this is logged as a stall
    double watchdog_s = 10;     // the service's WatchdogSec must be larger
};

struct CaptureSection {             // [capture]
    int map_width = 1024, map_height = 512;  // the environment map
    double target_coverage = 0.95;  // of the seeable sphere: the scan is complete
    double max_scan_s = 120;        // CAPTURE's timeout
};

struct ConvolutionSection {  // [convolution]
    double tolerance = 0.01; // weighted relative RMS of the final maps
};

struct ArSection {                      // [ar]
    std::string model = "teapot";       // teapot | sphere | a glTF or OBJ file
    double object_radius_m = 0.08;      // the object's bounding sphere on the marker
    double board_width_mm = 0;          // 0 = the default board's own size
    // The materials the button cycles through, in order (Phong, docs/render.md).
    std::vector<std::string> materials = {"matte", "glossy:160", "mirror"};
    // The object's shadow on the table under the room's dominant lights, baked against the mesh
    // once per visitor (docs/kiosk.md, "Shadows").
    bool shadows = true;
    // The camera matched on the object's pixels (docs/render.md, "Matching the camera"): the
    // sensor's noise when the calibration has "noise", and motion blur from the marker's motion.
    bool match_camera = true;
};

struct TimeoutsSection {            // [timeouts], seconds
    double attract_s = 0;           // 0 = ATTRACT waits for the button for ever
    double capture_s = 150;         // CAPTURE with no progress -> ATTRACT
    double processing_s = 60;       // PROCESSING not finished -> ATTRACT with an apology
    double ar_idle_s = 45;          // AR without a button press -> ATTRACT
    double message_s = 5;           // how long a friendly error message stays
};

struct MaintenanceSection {         // [maintenance]
    std::string pin_hash;           // crypt(3) hash of the PIN ("" = menu disabled without the key switch)
    int max_attempts = 5;           // wrong PINs before the lock-out
    double lockout_s = 300;
    std::string chord = "ctrl+alt+m";  // keyboard chord that asks for the PIN
};

struct StateSection {                       // [state]
    std::string dir = "/var/lib/glint";     // maps, calibrations, last scene, screenshots
    std::string export_dir = "/media/usb";  // where the maintenance menu exports to
};

struct Config {
    std::filesystem::path file;  // where it was read from ("" = defaults)
    DisplaySection display;
    CameraSection camera;
    SensorSection sensor;
    GpioSection gpio;
    FrameSection frame;
    CaptureSection capture;
    ConvolutionSection convolution;
    ArSection ar;
    TimeoutsSection timeouts;
    MaintenanceSection maintenance;
    StateSection state;
};

// Reads and validates `file`. Throws ConfigError (see above); a missing file is an error too.
Config load_config(const std::filesystem::path& file);
// The defaults (what an empty file gives).
Config default_config();

}  // namespace glint::ui
