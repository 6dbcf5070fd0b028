// libFuzzer target for recorded and kiosk sessions (appliance/capture/session.hpp,
// kiosk_session.hpp): one input is split at lines "#---#" into the files of a session
// directory, in this order
//   session.json, calibration.json, frames.csv, events.csv, kiosk.json, truth/board.csv,
//   truth/camera.csv
// (a piece that is not there is a file that is not there), written into a scratch directory in
// /dev/shm, then read as `glint replay` does: open_session(), load_session_events(),
// load_kiosk_info() (and the board it carries, board_spec_from_json), load_truth_board_poses()
// and load_truth_poses(). The frames' images are not read (OpenCV decodes them).
// Checks, besides memory safety under ASan and UBSan: every refusal is an InputError and
// nothing else; what is accepted keeps the documented rules (frame times increase, event times
// do not decrease, board poses belong to frames).
#include <cstddef>
#include <cstdint>
#include <string>

#include "appliance/capture/kiosk_session.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/tracking/board.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace {

const char* const kFiles[] = {"session.json", "events.csv", "kiosk.json", "truth/board.csv", "truth/camera.csv",
                              "calibration.json", "frames.csv"};
const int kOrder[] = {0, 5, 6, 1, 2, 3, 4};  // input pieces -> kFiles, in the order of the comment above

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace glint;
    const auto& dir = fuzz::scratch_dir("session");
    fuzz::clear_dir(dir);
    const auto pieces = fuzz::split(fuzz::as_text(data, size), "\n#---#\n");
    for (std::size_t i = 0; i < pieces.size() && i < std::size(kOrder); ++i)
        fuzz::write_file(dir / kFiles[kOrder[i]], pieces[i]);

    capture::Session s;
    try {
        s = capture::open_session(dir);
    } catch (const InputError&) {
        return 0;
    }
    fuzz::check(!s.frames.empty());
    for (std::size_t i = 1; i < s.frames.size(); ++i) fuzz::check(s.frames[i].t_ns > s.frames[i - 1].t_ns);
    try {
        const auto events = capture::load_session_events(s);
        for (std::size_t i = 1; i < events.size(); ++i) fuzz::check(events[i].t_ns >= events[i - 1].t_ns);
    } catch (const InputError&) {
    }
    try {
        if (const auto info = capture::load_kiosk_info(s)) {
            fuzz::check(!info->phases.empty());
            try {
                (void)tracking::board_spec_from_json(info->board_json, "kiosk.json board");
            } catch (const InputError&) {
            }
        }
    } catch (const InputError&) {
    }
    try {
        const auto poses = capture::load_truth_board_poses(s);
        for (std::size_t i = 1; i < poses.size(); ++i) fuzz::check(poses[i].t_ns > poses[i - 1].t_ns);
    } catch (const InputError&) {
    }
    if (s.has_truth) {
        try {
            (void)capture::load_truth_poses(s);
        } catch (const InputError&) {
        }
    }
    return 0;
}
