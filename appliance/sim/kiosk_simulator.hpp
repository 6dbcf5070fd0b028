// `glint simulate --kiosk`: a recorded kiosk session with the truth (docs/capture.md "Kiosk
// sessions"), what `glint replay` plays through the kiosk program. One camera, one calibration,
// one sensor stream over the whole visit:
//   1. attract: the device rests on its stand, looking at the board on the table;
//   2. a button press, then the built-in guided scan exactly as the capture benchmark takes it
//      (session_simulator.hpp: 35 deg/s, 3 fps, the exposure controller's brackets, 1 deg/min of
//      heading drift), simulated as if taken away from the table (the frames see the map alone,
//      so truth/env.exr stays the truth of the capture);
//   3. AR: the visitor walks slowly round the table looking at the board (an orbit 0.45-0.82 m
//      from it with a change of height), and once another visitor's arm passes in front of the
//      device and leaves the tracker too few markers for `dropout_s` (what the sensor bridge must
//      carry).
// The board (tracking's default, drawn by tracking::draw_board) lies on a finite table; both are
// diffuse and lit by the map's irradiance on an upward normal, and are seen through the same
// camera model as every other frame. Between the phases the device is carried (to the start of
// the scan, back to the table): the sensor stream goes on, no frames are recorded.
//
// Files beyond a session's (capture/kiosk_session.hpp): events.csv, kiosk.json, truth/board.csv.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "appliance/core/hdr_image.hpp"
#include "appliance/sim/session_simulator.hpp"

namespace glint::sim {

struct SimulateKioskOptions {
    std::filesystem::path env;  // equirect HDR map (EXR)
    std::filesystem::path out;  // session directory (must not exist unless overwrite)
    bool overwrite = false;
    std::function<void(const LoadedExr&)> on_environment;  // as SimulateOptions::on_environment
    std::uint64_t seed = 1;
    int threads = 0;  // render threads, 0 = all cores
    // One frame size for the whole session, chosen by measuring the tracker on the AR frames
    // and the session's size (docs/capture.md "Kiosk sessions").
    int width = 320, height = 180;
    double horizontal_fov_deg = 70;
    // Frames as JPEG at this quality (measured against PNG in docs/capture.md), or "png".
    std::string frame_format = "jpg";
    int jpeg_quality = 90;
    bool camera_noise = true;

    // The phases (seconds of camera time, frames per second).
    double attract_s = 3, attract_fps = 3;
    double scan_speed_deg_s = 35, scan_fps = 3;  // the capture benchmark's scan
    double heading_drift_deg_per_min = 1;
    double ar_s = 12, ar_fps = 12;
    // In the AR phase, the time an arm passing in front leaves fewer than 3 markers wholly in
    // view and uncovered (the tracker needs 3); 0: no dropout.
    double dropout_s = 0.3;
    // Presses of the button in the AR phase (the visitor trying the materials), evenly spread
    // over it: at (k + 1) / (n + 1) of the phase, each released after 80 ms.
    int material_presses = 2;

    // The table: its top at table_height_m above the floor (the world's origin, +Y up), centred
    // on the world's Y axis, table_width_m along world X, table_depth_m along Z; the board lies
    // at its centre, its top edge (+Y) away from the visitor (towards world -Z).
    double table_height_m = 0.75, table_width_m = 1.4, table_depth_m = 0.9;
    double table_albedo = 0.3;
};

struct KioskSummary {
    SimulateSummary session;
    int attract_frames = 0, scan_frames = 0, ar_frames = 0;  // scan_frames with the brackets
    double irradiance_up[3] = {0, 0, 0};  // the map's irradiance on an upward normal (R, G, B)
    // Camera time (from the first frame) during which fewer than 3 markers are wholly in view
    // and uncovered, and the speed of the arm that covers them.
    double dropout_start_s = 0, dropout_end_s = 0;
    std::int64_t dropout_start_ns = 0, dropout_end_ns = 0;  // the same on the appliance clock
    double sleeve_speed_m_s = 0;
};

// Writes the session (into OUT.partial, renamed to OUT at the end). progress(done, total) per
// frame. Throws InputError for bad options or inputs.
KioskSummary simulate_kiosk_session(const SimulateKioskOptions& options,
                                    const std::function<void(long long, long long)>& progress = {});

// The irradiance of `env` on a surface facing world +Y, per channel: the direct sum over the
// texels of L cos(theta) times their exact solid angle (conventions.md).
Rgb irradiance_up(const HdrImage& env);

}  // namespace glint::sim
