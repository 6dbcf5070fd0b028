// `glint capture`: a recorded or simulated session -> HDR environment map and coverage map
// (appliance/capture; docs/capture.md).
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "appliance/app/commands.hpp"
#include "appliance/app/cli_util.hpp"
#include "appliance/app/gpu_policy.hpp"
#include "appliance/capture/camera_factory.hpp"
#include "appliance/capture/capture_pipeline.hpp"
#include "appliance/capture/gpu_accumulator.hpp"
#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/progress.hpp"
#include "appliance/sim/session_simulator.hpp"

namespace glint::app {

Command add_capture_command(CLI::App& app) {
    struct Args {
        capture::CaptureOptions o;
        std::string session, out, size = "1024x512", orientations = "sensors", calibration_refinement = "stale";
        EngineChoice engine = EngineChoice::Auto;
        bool no_drift = false;
        bool no_adjust = false;
        bool no_rolling_shutter = false;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand("capture", std::string(command_summary("capture").summary));
    cmd->add_option("--session", a->session, "Session directory (glint simulate, or a recorded one)")->required();
    cmd->add_option("--out", a->out, "Environment map to write (OpenEXR, equirect)")->required();
    cmd->add_option("--size", a->size, "Environment map size WxH")->check(size_validator())->capture_default_str();
    cmd->add_flag("--no-drift-correction", a->no_drift, "Use the sensor orientations as they are");
    cmd->add_flag("--bracket-fill", a->o.bracket_fill,
                  "Experimental, off by default: fill a frame's clipped reads from the shorter frames of its "
                  "exposure bracket (CPU accumulation only; docs/capture.md, \"Bracket fill\")");
    cmd->add_option("--drift-gain", a->o.drift_gain,
                    "Low-pass gain of the drift correction: the share of each new measured offset taken into the "
                    "correction carried to the frames (0..1]")
        ->capture_default_str();
    cmd->add_flag("--no-global-adjustment", a->no_adjust,
                  "Keep the live pass's orientations: no pose graph of frame pairs and the sensor after the scan");
    cmd->add_option("--adjustment-rounds", a->o.adjustment_rounds,
                    "Run the global adjustment after the scan instead of during it, in this many rounds (frame "
                    "pairs aligned again from each solution, then solved): the mode before the adjustment ran "
                    "with the scan, kept for comparison");
    // The limits in the help come from the code's own (capture_pipeline.hpp).
    const auto number = [](double v) {
        char text[32];
        std::snprintf(text, sizeof text, "%g", v);
        return std::string(text);
    };
    const capture::CaptureOptions defaults;
    cmd->add_option("--calibration-refinement", a->calibration_refinement,
                    "After the scan, the camera-sensor mounting and time offset are refined with it: stale (keep "
                    "that solution when it turns the frames more than " + number(capture::kStaleMountingDeg) +
                        " degrees RMS or moves the time offset more than " + number(capture::kStaleTimeOffsetMs) +
                        " ms, and warn; from " + number(defaults.scan_check_from_s) +
                        " s into the scan it is also checked every " + number(defaults.scan_check_every_s) +
                        " s, and a calibration turning the frames more than " + number(defaults.scan_check_stale_deg) +
                        " degrees, from " + number(defaults.scan_check_late_from_s) + " s more than " +
                        number(defaults.scan_check_late_stale_deg) + " degrees or its time offset more than " +
                        number(defaults.scan_check_late_stale_offset_ms) +
                        " ms, is replaced there and then, so the map is rebuilt while the scan goes on), always, "
                        "or off (measured and reported, not kept). Only with the global adjustment during the scan "
                        "(not with --adjustment-rounds, --no-global-adjustment or --no-drift-correction)")
        ->check(CLI::IsMember({"stale", "always", "off"}))
        ->capture_default_str();
    cmd->add_option("--drift-log", a->o.drift_log,
                    "Write every frame's drift estimate (CSV: index, time, overlapping points, estimate and its "
                    "standard deviation in degrees, residual before and after, applied; on a simulated session also "
                    "the orientation error before and after and the sensor's error vector)");
    cmd->add_option("--orientations-out", a->o.orientations_out,
                    "Write the orientations the map was made with (CSV index,t_ns,w,x,y,z, world_from_camera: the "
                    "format of a simulated session's truth/camera.csv)");
    add_engine_option(*cmd, a->engine, "the accumulation as a fragment shader");
    cmd->add_option("--orientations", a->orientations,
                    "sensors (the session's recorded sensor stream) or truth (a simulated session's true "
                    "orientations: isolates the accumulation's own error)")
        ->check(CLI::IsMember({"sensors", "truth"}))
        ->capture_default_str();
    cmd->add_option("--min-samples", a->o.min_samples, "Frames that must see a texel for it to count as covered")
        ->capture_default_str();
    cmd->add_option("--max-blur-px", a->o.max_blur_px,
                    "Leave out a frame whose predicted motion blur (angular speed from the sensor stream x exposure "
                    "time x focal length) is more than this many pixels; 0 = no limit")
        ->check(non_negative_number())
        ->capture_default_str();
    cmd->add_flag("--no-rolling-shutter-correction", a->no_rolling_shutter,
                  "Turn every row of a frame with the frame's one orientation, although the calibration has a "
                  "rolling-shutter readout time (for measuring what the correction does)");
    cmd->add_option("--threads", a->o.threads, "Threads; 0 = all cores")
        ->check(non_negative_number())
        ->capture_default_str();
    return {cmd, [a, cmd] {
                const convolution::Size s = parse_size(a->size, "--size");
                a->o.width = s.width;
                a->o.height = s.height;
                a->o.session = a->session;
                a->o.out = a->out;
                // Checked before the work, not found at its end (a directory, a trailing slash, a
                // parent that cannot be written).
                const std::filesystem::path out(a->out);
                if (out.filename().empty() || std::filesystem::is_directory(out))
                    throw InputError("--out " + a->out + ": must name the environment map's file, not a directory");
                ensure_writable_directory(out.has_parent_path() ? out.parent_path() : std::filesystem::path("."));
                a->o.orientations = a->orientations == "truth" ? capture::OrientationInput::Truth
                                                               : capture::OrientationInput::Sensors;
                a->o.drift_correction = !a->no_drift;
                a->o.rolling_shutter = !a->no_rolling_shutter;
                a->o.global_adjustment = !a->no_adjust;
                a->o.online_adjustment = cmd->count("--adjustment-rounds") == 0;
                a->o.calibration_refinement = a->calibration_refinement == "always"
                                                  ? capture::CaptureOptions::CalibrationRefinement::Always
                                              : a->calibration_refinement == "off"
                                                  ? capture::CaptureOptions::CalibrationRefinement::Off
                                                  : capture::CaptureOptions::CalibrationRefinement::Stale;
                // The session's frames come from a camera source made by the factory; the
                // simulator's kind is registered here, where the binary's backends are chosen.
                capture::CameraBackends backends = capture::capture_camera_backends();
                sim::add_simulator_camera(backends);
                host::VirtualClock clock;  // offline: frames as fast as they are read
                const std::unique_ptr<capture::CameraSource> camera =
                    capture::make_camera_source("replay:" + a->session, backends, clock);
                // The experimental bracket fill is the CPU accumulator's only: refused on the GPU
                // engine before a context is made, and auto takes the CPU.
                if (a->o.bracket_fill && a->engine == EngineChoice::Gpu)
                    throw InputError("--bracket-fill: the GPU accumulator does not fill clipped reads; use --engine cpu");
                GpuChoice gpu(a->o.bracket_fill ? EngineChoice::Cpu : a->engine, "capture accumulation");
                if (gpu.context()) {
                    try {
                        capture::check_gpu_accumulation(*gpu.context());
                    } catch (const RuntimeError& e) {
                        gpu.give_up(e.what());
                    }
                }
                std::unique_ptr<ProgressBar> bar;
                const auto progress = [&](long long, long long t) {
                    if (!bar) bar = std::make_unique<ProgressBar>(a->o.global_adjustment && a->o.drift_correction
                                                                      ? "accumulate and adjust frames"
                                                                      : "accumulate frames",
                                                                  t);
                    bar->advance(1);
                };
                const capture::CaptureSummary r = capture::run_capture(a->o, *camera, gpu.context(), progress);
                if (bar) bar->finish();
                if (a->o.drift_correction)
                    std::printf("drift correction: %d of %d frames corrected, median correction %.3f degrees, median "
                                "residual %.4f -> %.4f (RMS log luminance against the sphere)\n",
                                r.drift_applied, r.drift_considered, r.drift_median_deg, r.drift_residual_before,
                                r.drift_residual_after);
                if (a->o.drift_correction && a->o.global_adjustment)
                    std::printf("global adjustment (%s): %d of %d frame pairs used, pair error %.3f degrees RMS, "
                                "sensor error %.3f degrees RMS, drift %.3f deg/min, %.2f s after the last frame for it\n",
                                a->o.online_adjustment ? "during the scan"
                                                       : (std::to_string(a->o.adjustment_rounds) + " rounds after the scan").c_str(),
                                r.adjust_pairs, r.adjust_pairs_tried, r.adjust_pair_rms_deg, r.adjust_sensor_rms_deg,
                                r.adjust_drift_deg_per_min, r.adjust_seconds);
                if (r.calibration_checked) {
                    const glm::dvec3& axis = r.calibration_mounting_axis;
                    const std::string calibration = (std::filesystem::path(a->session) / "calibration.json").string();
                    std::printf("camera-sensor calibration against the scan: mounting %.3f degrees about (%.2f, %.2f, "
                                "%.2f) (camera frame), time offset %+.2f ms, turning the frames %.3f degrees RMS "
                                "(against %s; %s)\n",
                                r.calibration_mounting_deg, axis.x, axis.y, axis.z, r.calibration_time_offset_ms,
                                r.calibration_turn_deg, calibration.c_str(),
                                r.calibration_refined ? "the map is made with the scan's values" : "the map keeps it");
                    if (r.calibration_refined_during_scan_s)
                        std::printf("camera-sensor calibration found stale during the scan, %.1f s in (the scan so "
                                    "far turned its frames %.2f degrees RMS): the scan's values were used from then "
                                    "on\n",
                                    *r.calibration_refined_during_scan_s, r.calibration_turn_during_scan_deg);
                    if (r.calibration_stale)
                        std::fprintf(stderr,
                                     "warning: %s looks stale: the scan turns its frames %.2f degrees RMS from it "
                                     "(mounting %.2f degrees, time offset %+.1f ms; the limits are %.1f degrees and "
                                     "%.0f ms). %s Run `glint calibrate alignment` on a new alignment session.\n",
                                     calibration.c_str(), r.calibration_turn_deg, r.calibration_mounting_deg,
                                     r.calibration_time_offset_ms, capture::kStaleMountingDeg,
                                     capture::kStaleTimeOffsetMs,
                                     r.calibration_refined
                                         ? "This map was made with the scan's own values; the live preview was not."
                                         : "This map was made with it (--calibration-refinement off).");
                }
                // A source clipped even at the sensor's shortest exposure is in the map by an
                // estimate, never a measurement: said so, with what is certain.
                for (const capture::EstimatedSource& source : r.estimated_sources)
                    std::printf("estimated source (clipped at the shortest exposure): direction (%.3f, %.3f, %.3f), "
                                "%.3g sr, energy %.4g (red, radiance x sr; at least %.4g)%s\n",
                                source.direction.x, source.direction.y, source.direction.z,
                                source.clipped_solid_angle, source.energy.r, source.lower_bound.r,
                                source.fitted ? "" : ", the lower bound: its halo said no more");
                const glm::dvec3& g = r.coverage.largest_gap;
                std::printf("%s: %d frames, coverage %.1f %% of the sphere, largest gap %.2f sr around "
                            "(%.3f, %.3f, %.3f), %lld texels filled\n",
                            a->out.c_str(), r.frames_used, 100 * r.coverage.covered_fraction, r.coverage.largest_gap_sr,
                            g.x, g.y, g.z, r.filled_texels);
                std::printf("coverage map: %s\n", r.coverage_path.c_str());
                if (r.guided_complete_after_s)
                    std::printf("guided capture: complete after %.1f s (95 %% of the seeable sphere); ", *r.guided_complete_after_s);
                else
                    std::printf("guided capture: not complete (%.1f %% of the seeable sphere); ", 100 * r.guided_final_coverage);
                std::printf("warnings: too fast %d, too bright %d, too dark %d frames\n", r.guided_too_fast,
                            r.guided_too_bright, r.guided_too_dark);
                if (a->o.max_blur_px > 0)
                    std::printf("motion blur: predicted median %.2f, max %.2f pixels; %d frames over %g px left out\n",
                                r.blur_median_px, r.blur_max_px, r.frames_blurred, a->o.max_blur_px);
                else
                    std::printf("motion blur: predicted median %.2f, max %.2f pixels (no limit)\n", r.blur_median_px,
                                r.blur_max_px);
                if (r.frames_without_orientation > 0)
                    std::printf("frames without an orientation (skipped): %d\n", r.frames_without_orientation);
                if (r.frames_after_sensor_end > 0)
                    std::fprintf(stderr,
                                 "glint: warning: %s/sensors.glrec: the orientations end %.2f s before the last frame; "
                                 "%d frames after them have none (a recording cut short?)\n",
                                 a->session.c_str(), r.sensor_end_before_last_frame_s, r.frames_after_sensor_end);
                if (r.orientation_error_median_deg)
                    std::printf("camera orientation against the session's truth: median %.3f, max %.3f degrees\n",
                                *r.orientation_error_median_deg, *r.orientation_error_max_deg);
                if (r.orientation_error_after_60s_max_deg)
                    std::printf("camera orientation error after 60 s: max %.3f degrees\n", *r.orientation_error_after_60s_max_deg);
                if (r.truth_error)
                    std::printf("against the session's truth (covered texels, %.1f %% of the sphere): weighted "
                                "relative RMS %.4f, median relative error %.4f\n",
                                100 * r.truth_error->covered_fraction_compared, r.truth_error->weighted_relative_rms,
                                r.truth_error->median_relative);
                return 0;
            }};
}

}  // namespace glint::app
