// The session simulator's machinery, for the simulators in this folder (not a public interface):
// one camera trajectory over the whole session, the sensor board's stream recorded along it, and
// frames taken in segments (a scan, the kiosk's attract and AR phases), each at its own rate,
// with or without the exposure controller's brackets and a local scene in front of the map.
// `glint simulate` is one segment; `glint simulate --kiosk` three (kiosk_simulator.hpp).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "appliance/core/hdr_image.hpp"
#include "appliance/sim/camera_simulator.hpp"
#include "appliance/sim/session_simulator.hpp"
#include "firmware_bridge/firmware/sim/trajectory.hpp"

namespace glint::sim::detail {

struct SessionSegment {
    std::uint64_t start_us = 0;  // camera time of the segment's first frame
    double fps = 4;
    int frames = 0;
    // The capture pipeline's exposure controller decides brackets (SimulateOptions::hdr_bracket);
    // at the segment's end a manual exposure still in force returns to auto-exposure.
    bool hdr_bracket = false;
    const LocalScene* scene = nullptr;  // null: the map alone; its clock is camera time, seconds
    // The camera's position (world frame, metres) at camera time t_s; needed with a scene.
    std::function<glm::dvec3(double t_s)> position;
};

// What was written for one frame (brackets included), in order.
struct WrittenFrame {
    std::uint64_t index = 0;
    std::int64_t t_ns = 0;     // frames.csv's time
    std::uint64_t tc_us = 0;   // camera time on the trajectory
    int segment = 0;
    glm::dquat world_from_camera{1, 0, 0, 0};
};

struct SessionPlan {
    const firmware::sim::Trajectory* camera = nullptr;  // world_from_camera over camera time from 0
    std::vector<SessionSegment> segments;               // in time order
    std::string created_by = "glint simulate";
    // truth/env.exr as a copy of this file (the map exactly as loaded, when the loader changed
    // nothing) instead of the loaded map saved as float; empty: saved.
    std::filesystem::path env_file;
    // Writes further files into the session being made (the partial directory), once the frames
    // are written; called before the session is renamed into place.
    std::function<void(const std::filesystem::path& partial, const std::vector<WrittenFrame>&)> finish;
};

// The appliance clock (ns) of camera time `camera_us` (the sensor's clock; a frame's own time
// is earlier by SimulateOptions::time_offset_s).
std::int64_t appliance_time_ns(const SimulateOptions& o, std::uint64_t camera_us);

// The true camera of `o` (size, field of view, lens, mounting, sensor limits).
capture::CameraCalibration true_camera(const SimulateOptions& o);

// The longest session written: the sensor board's path is kept at 200 Hz for the whole of it (a
// trajectory of 1e9 s asked for 10 GB before the first frame).
inline constexpr double kMaxSessionS = 3600;
// Throws InputError, `where` first (a trajectory file's name and ": ", or nothing), unless the
// trajectory lasts more than 0 s and at most kMaxSessionS.
void check_session_length(const firmware::sim::Trajectory& camera, const std::string& where);

// Writes the session of `plan` to o.out (into OUT.partial, renamed at the end). `o` gives the
// camera, the sensor board, the clocks, the frame format and the threads; o.fps, o.trajectory
// and o.hdr_bracket are the segments'. Throws InputError for bad options or inputs.
SimulateSummary write_planned_session(const SimulateOptions& o, const HdrImage& env, const SessionPlan& plan,
                                      const std::function<void(long long, long long)>& progress);

// Checks the options every session shares (size, field of view, sensors, clocks, frame format).
void check_common_options(const SimulateOptions& o);

}  // namespace glint::sim::detail
