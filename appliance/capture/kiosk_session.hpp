// The kiosk's additions to a session directory (docs/capture.md "Kiosk sessions"): what `glint
// replay` needs beyond the camera frames and the sensor stream to play a session through the
// kiosk program, and the truth of the AR phase.
//
//   SESSION/events.csv       t_ns,source,event   (appliance clock, as frames.csv; e.g. button,press)
//   SESSION/kiosk.json       {"format": "glint-kiosk-session", "version": 1, "phases": [...],
//                             "board": {...}, "table_height_m": ..., "world_from_board": {...}}
//   SESSION/truth/board.csv  index,t_ns,qw,qx,qy,qz,tx,ty,tz: true camera_from_board (OpenCV's
//                            camera frame, metres) of every frame of the AR phase
//
// Capture does not know the board's layout (that is tracking's): the "board" object is handed
// on as JSON text for tracking::board_spec_from_json. Each reader returns an empty result when
// its file is absent (a session recorded without the kiosk), and throws InputError naming the
// file and the line or key for anything malformed.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "appliance/capture/session.hpp"

namespace glint::capture {

inline constexpr int kKioskSessionVersion = 1;

struct SessionEvent {
    std::int64_t t_ns = 0;  // appliance clock, ns
    std::string source;     // "button"
    std::string event;      // "press", "release"
};

struct KioskPhase {
    std::string name;  // "attract", "scan", "ar"
    std::int64_t start_ns = 0, end_ns = 0;
};

struct KioskSessionInfo {
    std::vector<KioskPhase> phases;  // attract, scan, ar (in order)
    std::string board_json;          // the "board" object as JSON text (tracking::board_spec_from_json reads it)
    double table_height_m = 0;       // the table top above the world's origin (the floor), metres
    // The board's place in the world (docs/conventions.md, +Y up; the board frame of
    // docs/tracking.md): x_world = world_from_board * x_board + world_board_t.
    glm::dquat world_from_board{1, 0, 0, 0};
    glm::dvec3 world_board_t{0};
    const KioskPhase* phase(const std::string& name) const;  // nullptr when absent
};

struct TruthBoardPose {
    std::uint64_t index = 0;  // the frame's index in frames.csv
    std::int64_t t_ns = 0;
    glm::dquat camera_from_board{1, 0, 0, 0};  // OpenCV camera frame (+X right, +Y down, +Z forward)
    glm::dvec3 t_m{0};                         // x_camera = camera_from_board * x_board + t_m
};

// events.csv: times must not decrease; source and event are non-empty words. Empty when absent.
std::vector<SessionEvent> load_session_events(const Session& s);
// kiosk.json. nullopt when absent.
std::optional<KioskSessionInfo> load_kiosk_info(const Session& s);
// truth/board.csv: times must increase. Empty when absent.
std::vector<TruthBoardPose> load_truth_board_poses(const Session& s);

// Writing (for the simulator and for recording live sessions).
std::string session_events_csv_header();  // "t_ns,source,event"
std::string session_events_csv_line(const SessionEvent& e);
std::string kiosk_json(const KioskSessionInfo& info);  // throws InputError if board_json is not an object
std::string truth_board_csv_header();  // "index,t_ns,qw,qx,qy,qz,tx,ty,tz"
std::string truth_board_csv_line(const TruthBoardPose& p);

}  // namespace glint::capture
