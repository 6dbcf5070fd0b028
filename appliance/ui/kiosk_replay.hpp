// `glint replay SESSION --out DIR`: the kiosk program on a recorded session (docs/kiosk.md,
// "Replay"). The session's camera frames, sensor stream and button events are delivered on a
// replay clock; the visitor flow (kiosk_flow.hpp), the capture (capture_job.hpp), the maps and the
// AR view run as they would live, and the frames go to a display (headless by default).
//
// Clock: as fast as possible unless `realtime`. Each loop iteration is one display frame of the
// budget's length on the replay clock; while the capture takes in a frame the loop waits for it
// (so the guide decides exactly as it would live, whatever the machine's speed), and while the
// scan's map is finished after the last frame the loop runs at wall-clock pace (that wait is what
// a visitor sees). The states reached and their order are deterministic; times after PROCESSING
// depend on the machine's speed.
//
// Writes DIR/frames/*.png at each state change and every `snapshot_every_s` of replay time, the
// maps of the visitor's scene (DIR/env.exr and its coverage), and DIR/summary.json.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "appliance/ui/config.hpp"
#include "appliance/ui/screen_model.hpp"

namespace glint::ui {

struct ReplayOptions {
    std::filesystem::path session;
    std::filesystem::path out;
    bool realtime = false;
    Config config;                 // display kind and size, budgets, timeouts, capture and AR settings
    double snapshot_every_s = 5;   // PNG frames between state changes (replay seconds; 0: none)
    int threads = 0;               // capture and convolution workers (0: all cores but the frame thread's)
    // Makes, once the display's context is current, what draws the visitor screen over each frame
    // (the screens library); empty: no overlay.
    using Overlay = std::function<void(const ScreenModel&, double dt_s)>;
    std::function<Overlay(int width, int height)> make_overlay;
    // Called once per frame with the replay clock and the session's length (seconds).
    std::function<void(double t_s, double end_s)> progress;
};

// Runs the replay; returns summary.json's content (also written to OUT/summary.json). Throws
// InputError for an unusable session or output directory, RuntimeError for GL failures.
nlohmann::json run_replay(const ReplayOptions& options, const std::function<void(const std::string&)>& log);

}  // namespace glint::ui
