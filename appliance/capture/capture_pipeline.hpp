// `glint capture`: a recorded or simulated session -> HDR environment map + coverage map, offline.
// Frames are taken in order from a camera source; each frame's orientation is the sensor's
// orientation at the frame's time (plus the calibrated time offset), rotated by the calibrated
// alignment; the frame is accumulated on the sphere (hdr_accumulator.hpp); at the end the unseen
// parts are filled by the coverage rule (coverage.hpp) and both maps are saved atomically.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "appliance/capture/camera_source.hpp"
#include "appliance/capture/coverage.hpp"
#include "appliance/capture/guided_capture.hpp"
#include "appliance/capture/hdr_accumulator.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/exr_io.hpp"

namespace glint::gl {
class GlContext;
}  // namespace glint::gl

namespace glint::capture {

enum class OrientationInput {
    Sensors,  // the session's recorded sensor stream (what the appliance has)
    Truth,    // a simulated session's true camera orientations (isolates the accumulation's error)
};

struct CaptureOptions {
    // The session's calibration, sensor recording and (simulated sessions) truth; its frames come
    // from the camera source given to run_capture.
    std::filesystem::path session;
    std::filesystem::path out;  // env.exr; the coverage map goes to <stem>.coverage.exr beside it
    // How both are written: ZIP by default (`glint capture`); the kiosk writes them uncompressed,
    // since its visitor waits for the write and float noise barely compresses (docs/kiosk.md).
    ExrCompression compression = ExrCompression::Zip;
    int width = 1024, height = 512;
    OrientationInput orientations = OrientationInput::Sensors;
    bool drift_correction = true;  // align each frame to the sphere before accumulating it
    // Experimental, off by default: fill clipped reads from their brackets' shorter frames
    // (AccumulationSettings::bracket_fill, docs/capture.md "Bracket fill"); CPU accumulation only.
    bool bracket_fill = false;
    double drift_gain = 0.1;       // low-pass gain of the drift correction (DriftSettings::gain)
    // The global adjustment after the scan (global_adjustment.hpp); only with drift correction on.
    bool global_adjustment = true;
    // Rounds of pair alignment and solve, each from the last solution (after the scan; only
    // without online_adjustment).
    int adjustment_rounds = 4;
    // The adjustment while the scan runs (OnlineAdjustment): pairs aligned in the frame loop, and
    // again whenever the solution moved their start more than realign_deg, at most
    // realign_per_frame per frame; after the last frame final_realign_passes more such steps
    // (a solve, at most realign_per_frame pairs aligned again), then a solve.
    bool online_adjustment = true;
    // After the scan (online adjustment only) the camera-sensor calibration is refined with it
    // (AdjustmentSettings::refine_calibration); that solution is kept when the refinement turns
    // the frames by more than kStaleMountingDeg or moves the time offset by more than
    // kStaleTimeOffsetMs (Stale), always (Always), or never (Off: it is still measured and
    // reported).
    enum class CalibrationRefinement { Stale, Always, Off };
    CalibrationRefinement calibration_refinement = CalibrationRefinement::Stale;
    // The same check during the scan (Stale only): from scan_check_from_s of scan time on, every
    // scan_check_every_s, a solve with the calibration refined; when it turns the frames more than
    // scan_check_stale_deg the calibration is stale beyond doubt and that solution is kept there
    // and then, so that the pairs' new alignments and the kept map's rebuild (below) run while the
    // visitor still scans instead of after the last frame (a mounting 3 degrees off, checked
    // after the scan: 14 s from the last frame to the map in glint capture, 9.6 s in the kiosk).
    // A partial scan's refinement finds more than a whole one's: with right calibrations it
    // turned the frames up to 0.65-0.83 degrees at 17-19 s and under 0.4 only from 34-36 s, with
    // a mounting 3 degrees off 1.6-2.0 degrees by 12-17 s; hence the later start and the higher
    // limit than kStaleMountingDeg. scan_check_from_s = 0: no check during the scan.
    // From scan_check_late_from_s the limit is scan_check_late_stale_deg, and the time offset's
    // limit scan_check_late_stale_offset_ms applies (equal limits leave one turn limit; a late
    // start past the scan's end leaves the first limit alone, and no time offset limit during
    // the scan): a partial scan's turn
    // shrinks as the scan goes on. Over 42 sessions with right calibrations (the quick capture
    // benchmark, 2026-12-07) the largest partial turn was 0.51 degrees at 35 s, 0.38 at 40 s and
    // 0.33 at 45 s; on the kiosk session with its mounting 0.5 degrees off, or its time offset 25 ms
    // off, it was 0.69-0.72 at 40 s, so those are now found at 40 s instead of after the scan
    // (10-13 s from the last frame to the map). Smaller staleness is still found after the scan.
    double scan_check_from_s = 35;
    double scan_check_every_s = 5;
    double scan_check_stale_deg = 1.0;
    double scan_check_late_from_s = 40;
    double scan_check_late_stale_deg = 0.6;
    // From scan_check_late_from_s also a time offset's change beyond this (ms; after the scan
    // kStaleTimeOffsetMs, which says why): a turn's RMS hides a time offset more than a mounting.
    double scan_check_late_stale_offset_ms = 7.0;
    // After the last frame of a scan whose calibration was kept during it, the pairs whose start
    // moved more than this since they were aligned are aligned again (an adoption near the end
    // leaves pairs aligned from the stale start; the frame loop catches up with the others).
    double scan_check_realign_deg = 0.1;
    int realign_per_frame = 24;
    double realign_deg = 0.01;
    int final_realign_passes = 1;
    // The adjusted map kept during the scan (online adjustment only): frames older than the last
    // map_tail_frames accumulated with the current solution, the map made again, at most
    // map_rebuild_per_frame frames per frame, when the solution moved one of its frames more than
    // map_rebuild_deg; after the last frame a rebuild under way is finished only when the map is
    // more than map_accept_deg off the final solution and fewer than map_finish_max_frames are
    // left, then the tail is added. A map begun before a calibration kept during the scan, or
    // whose frames are more than map_redo_deg off the final solution, is never the final map: a
    // rebuild begun after it is finished, else every frame is accumulated again. Off: every frame
    // accumulated again after the scan.
    bool keep_map = true;
    int map_tail_frames = 12;
    double map_rebuild_deg = 0.05;
    int map_rebuild_per_frame = 6;
    double map_accept_deg = 0.1;
    int map_finish_max_frames = 12;
    double map_redo_deg = 1.0;
    // Per-frame log of the drift estimates (CSV: index,t_s,pixels,estimate_deg,sigma_deg,
    // residual_before,residual_after,applied,error_before_deg,error_after_deg; the errors against a
    // simulated session's truth, NaN otherwise); empty = none.
    std::filesystem::path drift_log;
    // The orientations the map was made with (CSV: index,t_ns,w,x,y,z, world_from_camera, the
    // truth/camera.csv format); empty = none.
    std::filesystem::path orientations_out;
    int min_samples = 1;
    int threads = 0;
    // Motion blur: a frame whose predicted blur (the camera's angular speed from the sensor stream
    // around the frame's time x its exposure time x the calibration's focal length, pixels)
    // exceeds this is not used at all (no alignment, not accumulated) and is counted
    // (CaptureSummary::frames_blurred). 0: no limit. docs/capture.md "Blurred frames".
    double max_blur_px = 16.0;
    // The rolling shutter (calibration readout_s): each row turned into the world with the
    // orientation at its readout time, from the sensor's angular velocity. Off: the frame's one
    // orientation for every row (for measuring what the compensation does).
    bool rolling_shutter = true;
    // Live capture (the kiosk's `glint run`): no session directory; the calibration on file and
    // the orientation sensor's world_from_sensor at a sensor time (nullopt: none known), which may
    // block briefly until the stream has reached that time. `session` is then not read.
    std::optional<CameraCalibration> live_calibration;
    std::function<std::optional<glm::dquat>(std::int64_t sensor_t_ns)> live_orientation;
    // The guided-capture logic run over the frames (its target coverage and time limit).
    GuidedSettings guided;
    // Called on the capture's thread after every accumulated frame (the kiosk draws the arrow, the
    // minimap and the progress from it while the scan runs): the guide's step, the orientation the
    // frame was accumulated with, and the per-texel sample counts of the live map (width x height).
    std::function<void(const GuidedStep&, const glm::dquat& world_from_camera, const std::vector<std::uint32_t>& samples)>
        on_frame;
};

struct GroundTruthError {
    double weighted_relative_rms = 0;  // over covered texels, against truth/env.exr at this size
    double median_relative = 0;
    double covered_fraction_compared = 0;
};

// A refinement of the camera-sensor calibration that turns the frames by more than this (RMS,
// AdjustmentResult::calibration_turn_deg) says calibration.json is stale: `glint capture` then
// keeps the refined solution, warns and names `glint calibrate alignment`. Above what it turns a
// right calibration's scan by, mostly the board's fusion lag read as a time offset: 0.14-0.23
// degrees with the raw IMU (3.4 ms) and 0.33 with the BNO055 (8 ms) on 13 courtyard and sunset
// sessions of other speeds, rates, drifts and noise; a solution refined that little was as often
// worse as better (docs/capture.md "Global adjustment").
// (A limit on the turn of the mounting and the time offset together: at one speed of turn the
// scan cannot tell them apart. The guided scan's changes of speed do, well enough for the limit on
// the time offset below: a BNO055's lag read as +8.1 ms with 0.006 degrees of mounting.)
inline constexpr double kStaleMountingDeg = 0.4;
// ... or that moves the time offset by more than this. A time offset off turns the fast frames
// most, and they are what blur the map, while the turn above is an RMS over every frame: on the
// shipped kiosk session a time offset 15 ms off (read as -11.4 ms against the fusion's own
// +3.5) turned the frames 0.398 degrees and was not found, its map 0.137 weighted relative RMS
// against the truth where the scan's values give 0.0746 (docs/capture.md, "A limit on the time
// offset"). Right calibrations of the raw IMU (42 sessions of the quick capture benchmark,
// 2026-12-08, with the sensor path in time) read +0.5 to +2.1 ms over the whole scan and up to
// +3.6 ms in the partial scans from 40 s (+2.3 to +3.9 and +5.6 before that day: docs/capture.md,
// "Where the raw IMU's lag came from"); a BNO055 whose calibration.json lacks the lag of the
// chip's fusion output (held 10 ms, 100 Hz) reads +3.5 ms, which `glint calibrate alignment` on
// that board measures into the file.
inline constexpr double kStaleTimeOffsetMs = 7.0;
// A refinement finds the calibration stale: its turn of the frames beyond turn_limit_deg, or its
// time offset's change beyond offset_limit_ms (either sign). A NaN or infinite figure is none.
bool calibration_turn_or_offset_stale(double turn_deg, double time_offset_ms, double turn_limit_deg,
                                      double offset_limit_ms);

struct CaptureSummary {
    int frames_used = 0;
    int frames_without_orientation = 0;
    // Of those, the frames more than a second after the sensor recording's last orientation, and how long before
    // the last frame it ends (seconds): a recording cut short (0 without a recording).
    int frames_after_sensor_end = 0;
    double sensor_end_before_last_frame_s = 0;
    // Frames over CaptureOptions::max_blur_px (not used), and the predicted blur of the frames
    // with an orientation (pixels, median and max; 0 without a sensor stream).
    int frames_blurred = 0;
    double blur_median_px = 0, blur_max_px = 0;
    CoverageReport coverage;
    long long filled_texels = 0;
    std::filesystem::path coverage_path;
    std::optional<GroundTruthError> truth_error;  // simulated sessions only
    // Camera-orientation error of the frames as the map was made (after the global adjustment).
    std::optional<double> orientation_error_median_deg, orientation_error_max_deg;  // ditto
    // ... and of the live pass alone (what the kiosk had while scanning).
    std::optional<double> live_orientation_error_median_deg, live_orientation_error_max_deg,
        live_orientation_error_after_60s_max_deg;
    // Global adjustment: candidate pairs, pairs measured, RMS of the pair and sensor errors after
    // the solve, the drift rate found, wall time (alignment and solve, not the final map).
    int adjust_pairs_tried = 0, adjust_pairs = 0;
    double adjust_pair_rms_deg = 0, adjust_sensor_rms_deg = 0, adjust_drift_deg_per_min = 0, adjust_seconds = 0;
    // The camera-sensor calibration as the adjustment refined it against calibration.json
    // (AdjustmentSettings::refine_calibration): the mounting's rotation (degrees), the time
    // offset's change (ms) and the RMS turn of the frames they make (degrees; the largest of the
    // refined solves after the scan, or the last solve's when the check during the scan kept
    // one); calibration_stale: that turn beyond kStaleMountingDeg, or the time offset's change
    // beyond kStaleTimeOffsetMs, in any refined solve after the scan. The mounting and time offset
    // are the last solve's, which the map used (calibration_of_scan reads them), so an adopted
    // solve's offset can sit just under the limit that an earlier solve passed.
    double calibration_mounting_deg = 0, calibration_time_offset_ms = 0, calibration_turn_deg = 0;
    glm::dvec3 calibration_mounting_axis{0};  // camera frame, unit (0 when no refinement)
    bool calibration_stale = false;
    bool calibration_refined = false;  // the map was made with the refined solution
    bool calibration_checked = false;  // a refined solve ran (online adjustment): the figures above hold
    // Seconds into the scan when the check during it found the calibration stale and the scan's
    // own values were taken from then on (CaptureOptions::scan_check_stale_deg, and from
    // scan_check_late_from_s scan_check_late_stale_deg or scan_check_late_stale_offset_ms;
    // nullopt: not so), and the turn that
    // check's refined solve found (a partial scan's, larger than the whole scan's:
    // calibration_turn_deg and calibration_stale are then the last solve's).
    std::optional<double> calibration_refined_during_scan_s;
    double calibration_turn_during_scan_deg = 0;
    // Every check during the scan, kept or not (how near right calibrations come to the check's
    // limits).
    struct CalibrationCheck {
        double t_s = 0;             // seconds into the scan
        double turn_deg = 0;        // the refined solve's turn of the frames (RMS)
        double time_offset_ms = 0;  // its time offset's change
    };
    std::vector<CalibrationCheck> calibration_checks_during_scan;
    // Wall times after the last frame of the scan: the alignment views, the final accumulation,
    // and from the last frame to the finished map (radiance merged and filled) and to it saved;
    // adjust_profile: the adjustment's own breakdown (pair selection, alignment, solve).
    double adjust_views_seconds = 0, final_accumulate_seconds = 0, last_frame_to_map_seconds = 0,
           last_frame_to_saved_seconds = 0;
    std::string adjust_profile;
    // The online adjustment's work in the frame loop: summed over the scan and the most of one
    // frame (seconds), and the pair alignments it did in all.
    double online_seconds = 0, online_max_frame_seconds = 0;
    long long adjust_alignments = 0;
    // The kept map: its work in the frame loop (summed, most in one frame), how often it was made
    // again, how far its frames' orientations ended from the final solution (degrees), and the
    // final solution's own error after 60 s (the map's is orientation_error_after_60s_max_deg).
    double map_seconds = 0, map_max_frame_seconds = 0, map_deviation_deg = 0;
    int map_rebuilds = 0, map_final_frames = 0;  // frames accumulated after the last frame
    double radiance_seconds = 0;                 // merging the map's exposure bands at the end
    std::optional<double> adjusted_after_60s_max_deg;
    // Sources still clipped at the calibration's shortest exposure, whose energy in the map is
    // an estimate (hdr_accumulator.hpp; CPU engine only; none without a shortest exposure).
    std::vector<EstimatedSource> estimated_sources;
    // Drift correction (when on): frames it corrected, the median correction, and the median
    // RMS log-luminance residual against the sphere before and after it.
    // The guided-capture logic run over the session as if live (guided_capture.hpp): when it would
    // have said "complete" (seconds from the first frame; nullopt: never), and how often it would
    // have warned.
    std::optional<double> guided_complete_after_s;
    int guided_too_fast = 0, guided_too_bright = 0, guided_too_dark = 0;
    double guided_final_coverage = 0;
    int drift_applied = 0, drift_considered = 0;
    double accumulate_seconds = 0, drift_seconds = 0;  // wall time summed over the frames
    double exposure_stops = 0;  // log2 of the largest over the smallest exposure x gain of the frames
    // Camera-orientation error against truth (simulated sessions) of the frames after 60 s of
    // session time: median and max; nullopt when the session is shorter.
    std::optional<double> orientation_error_after_60s_max_deg;
    double drift_median_deg = 0, drift_residual_before = 0, drift_residual_after = 0;
};

// The scan's check of the camera-sensor calibration in one line, as the kiosk logs it and its
// maintenance menu shows it: "n/a" when no refined solve ran; "ok: ..." within
// kStaleMountingDeg and kStaleTimeOffsetMs; "stale: ..." with the figures and what to do (a new
// alignment calibration: only that mends the live view).
std::string calibration_check_text(const CaptureSummary& summary);

// The calibration the scan's map was made with: `file` (calibration.json) with the mounting and
// time offset the scan refined when it kept them (CaptureSummary::calibration_refined), else
// `file` itself. What shows the map in the live camera's view (the kiosk's AR) must use the same,
// or the map's light turns against the camera by what the scan found.
CameraCalibration calibration_of_scan(const CameraCalibration& file, const CaptureSummary& summary);

std::filesystem::path coverage_path_for(const std::filesystem::path& env_out);

// The orientation stream of a session's sensor recording, as the live driver published it
// (appliance clock; a serial board's bytes decoded again, an I2C or Modbus source's samples as
// recorded): for the kiosk's replay, which feeds it to the tracker's
// dropout bridge and the AR view. Throws InputError naming the file.
struct SensorOrientation {
    std::int64_t t_ns = 0;
    glm::dquat world_from_sensor{1, 0, 0, 0};
};
std::vector<SensorOrientation> load_sensor_orientations(const Session& session);

// A rolling-shutter frame resampled to what a global shutter would have seen at the frame's time,
// for the drift correction and the pair alignment (they turn every pixel with the frame's one
// orientation): each pixel read, bilinearly in code values, where its ray (pixel_rays[v * width +
// u], pixel_ray()) fell in the row that saw it while the camera turned at angular_velocity (camera
// frame, rad/s; rolling_shutter_project). A channel beside a clipped code stays clipped (255), and
// so is a pixel no row saw: every reader leaves clipped cells out.
CameraFrame deskew_rolling_shutter(const CameraFrame& frame, const CameraCalibration& calibration,
                                   const std::vector<glm::dvec3>& pixel_rays, const glm::dvec3& angular_velocity,
                                   int threads = 1);

// camera: the session's frames. It is read from start() until finished() once, and twice more
// with the global adjustment (alignment views, then the final map), so it must give the same
// frames again after start(): a replay of the session (camera_factory.hpp) or the simulator.
// gpu: accumulate with gpu_accumulator.hpp on this context (current on the calling thread, made
// by the caller); null: on the CPU.
CaptureSummary run_capture(const CaptureOptions& options, CameraSource& camera, const gl::GlContext* gpu = nullptr,
                           const std::function<void(long long, long long)>& progress = {});

}  // namespace glint::capture
