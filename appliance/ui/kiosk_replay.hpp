// `glint replay SESSION --out DIR`: the kiosk program (kiosk_loop.hpp) on a recorded session
// (docs/kiosk.md, "Replay"). The session's camera frames, sensor stream and button events are
// delivered on the loop's own clock: one frame period a frame, as fast as the machine goes; the
// capture takes in every frame before the guide is asked (so it decides as it would live,
// whatever the machine's speed); while the scan's map is finished the loop runs at wall-clock
// pace (that wait is what a visitor sees). With `realtime` the session plays at its recorded pace.
// The states reached and their order are deterministic; times after PROCESSING depend on the
// machine's speed.
//
// Writes DIR/frames/*.png at each state change and every `snapshot_every_s`, DIR/env.exr (the
// visitor's map) and DIR/summary.json: the loop's figures, and against a simulated session's
// truth the map's and the irradiance's errors and the tracking's rotation error.
//
// Soak (`--loop-for S` / `--repeat N`, docs/kiosk.md "Soak"): the session replayed pass after pass
// in this one process, on one display and GL context opened once; each pass is a whole replay
// (a new source, the kiosk loop from its start). DIR/soak.csv gets a row every
// `sample_every_s` of wall time and one after each pass: resident memory, the heap in use and
// what the allocator holds, open descriptors, threads, live GL objects per kind (gl_objects.hpp)
// and the pass's frame-time median and p99. The outputs above are the last pass's.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "appliance/ui/fault_injection.hpp"
#include "appliance/ui/kiosk_loop.hpp"

namespace glint::ui {

struct ReplayOptions {
    std::filesystem::path session;
    std::filesystem::path out;
    bool realtime = false;
    KioskOptions kiosk;  // config, snapshots, threads, overlay, progress (dirs are set from `out`)
    FaultPlan faults;    // --inject-fault (fault_injection.hpp)
    // Soak: passes start while the run is younger than loop_for_s (> 0), or exactly `repeat`
    // passes (> 0); neither: one pass as ever, no soak.csv.
    double loop_for_s = 0;
    int repeat = 0;
    double sample_every_s = 5;  // soak.csv's rows within a pass (wall seconds)
};

// Returns summary.json's content (also written to OUT/summary.json). Throws InputError for an
// unusable session or output directory, RuntimeError for GL failures.
nlohmann::json run_replay(const ReplayOptions& options, const std::function<void(const std::string&)>& log);

}  // namespace glint::ui
