// The kiosk program's frame loop (docs/kiosk.md): one loop for `glint run` and `glint replay`.
// Each frame: the inputs that arrived (camera frames, orientation samples, button and key
// events), the visitor flow (kiosk_flow.hpp), the capture fed frame by frame (capture_job.hpp),
// the maps (coarse at once, final in the frames' leftover time), tracking and the AR view, the
// visitor screen over it, present; each phase timed against the budget (frame_scheduler.hpp).
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "appliance/capture/capture_pipeline.hpp"
#include "appliance/core/hdr_image.hpp"
#include "appliance/gl/display.hpp"
#include "appliance/ui/config.hpp"
#include "appliance/ui/device_watch.hpp"
#include "appliance/ui/kiosk_source.hpp"
#include "appliance/ui/screen_model.hpp"

namespace glint::ui {

struct KioskOptions {
    Config config;
    std::filesystem::path maps_dir;    // where each visitor's env.exr (and coverage) is written
    std::filesystem::path frames_dir;  // PNG frames at each state change and every snapshot_every_s ("" = none)
    double snapshot_every_s = 5;
    std::filesystem::path frame_log;   // CSV, one line a frame: t_s,state,ms and each phase's ms ("" = none)
    int threads = 0;                   // capture and convolution workers (0: the cores but the frame thread's)
    // Draws over the frame; gets this frame's keys (window display) and returns true while it
    // takes the keyboard itself (the maintenance menu is open: keys are not the visitor's button).
    using Overlay = std::function<bool(const ScreenModel&, double dt_s, const std::vector<gl::InputEvent>& keys)>;
    // Makes, once the display's context is current, what draws the visitor screen over each frame.
    std::function<Overlay(int width, int height)> make_overlay;
    // Once a frame: the kiosk clock and how long the input lasts (0: unknown, live).
    std::function<void(double t_s, double end_s)> progress;
    // Once a frame, what arrived (frames out of order already dropped), before the visitor flow
    // takes it: the maintenance menu's calibration wizards look at the same frames and samples.
    std::function<void(const KioskPoll&)> observe_input;
    // Polled once a frame: true ends the loop cleanly (SIGTERM).
    std::function<bool()> stop_requested;
    // After each frame is on screen (READY after the first, STATUS on a change, WATCHDOG pings).
    std::function<void(KioskState state, long long frame)> after_present;
    // Polled once a frame: a new configuration to apply (SIGHUP); only its live keys are used.
    std::function<std::optional<Config>()> reload;
    // When the camera counts as stalled and the sensor as lost (device_watch.hpp).
    DeviceWatchSettings devices;
    // --inject-fault gl-lost:AT (fault_injection.hpp): the context reports itself lost at AT s.
    std::optional<double> fault_gl_lost_at_s;
    // An already-open display to draw on (its context current), kept open after the loop; null:
    // the loop opens the configured one and closes it at its end. The soak replay
    // (kiosk_replay.hpp) runs pass after pass on one display and context.
    gl::Display* display = nullptr;
};

struct KioskResult {
    nlohmann::json summary;  // states, frame_ms, scan_end_to_lit_s, coverage, tracking, ...
    std::optional<capture::CaptureSummary> capture;  // the last visitor's scan
    std::optional<HdrImage> env;                     // ... and the map the object was lit by
};

// The display section of the configuration as gl::open_display takes it.
gl::DisplayConfig display_config_of(const Config& config);

KioskResult run_kiosk(KioskSource& source, const KioskOptions& options, const std::function<void(const std::string&)>& log);

}  // namespace glint::ui
