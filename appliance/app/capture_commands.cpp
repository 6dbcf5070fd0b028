// `glint simulate` and `glint capture` (appliance/capture, appliance/sim; docs/capture.md).
#include <cmath>
#include <cstdio>
#include <memory>

#include "appliance/app/cli_util.hpp"
#include "appliance/app/commands.hpp"
#include "appliance/capture/calibration.hpp"
#include "appliance/capture/calibration_io.hpp"
#include "appliance/capture/camera_factory.hpp"
#include "appliance/capture/capture_pipeline.hpp"
#include "appliance/capture/charuco.hpp"
#include "appliance/capture/libcamera_source.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/progress.hpp"
#include "appliance/gl/gl_context.hpp"
#include "appliance/sim/session_simulator.hpp"

namespace glint::app {

Command add_simulate_command(CLI::App& app) {
    struct Args {
        sim::SimulateOptions o;
        std::string env, out, size = "320x180", mount = "2,-1.5,0.5";
        bool no_camera_noise = false;
        int charuco = 0;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand(
        "simulate", "Render a recorded capture session with ground truth from an equirect HDR map: camera frames "
                    "through a camera model (distortion, vignetting, response, noise, auto-exposure) along a "
                    "trajectory, and the sensor board's recorded stream from its firmware simulator");
    cmd->add_option("--env", a->env, "Equirect HDR environment map (OpenEXR); not with --charuco");
    cmd->add_option("--trajectory", a->o.trajectory,
                    "guided (the built-in scan: rings at -60..60 degrees and the zenith, ~52 s) or a file of "
                    "lines t_seconds,w,x,y,z (camera-to-world, conventions' frame)")
        ->capture_default_str();
    cmd->add_option("--out", a->out, "Session directory to create")->required();
    cmd->add_flag("--force", a->o.overwrite, "Replace an existing session directory");
    cmd->add_option("--fps", a->o.fps, "Frames per second")->capture_default_str();
    cmd->add_option("--size", a->size, "Frame size WxH, pixels")->capture_default_str();
    cmd->add_option("--fov", a->o.horizontal_fov_deg, "Horizontal field of view, degrees")->capture_default_str();
    cmd->add_option("--imu", a->o.imu, "Sensor board IMU: raw (MPU-6050 + QMC5883L, fused on the board) or bno055")
        ->capture_default_str();
    cmd->add_option("--sensor-noise", a->o.sensor_noise, "Sensor error preset: none, default, high")
        ->capture_default_str();
    cmd->add_flag("--no-camera-noise", a->no_camera_noise, "Render without shot and read noise");
    cmd->add_option("--mount", a->mount, "Sensor mounting error yaw,pitch,roll in degrees (sensor_from_camera)")
        ->capture_default_str();
    cmd->add_option("--clock-drift-ppm", a->o.clock_drift_ppm, "Board clock rate error against the appliance clock")
        ->capture_default_str();
    cmd->add_option("--seed", a->o.seed, "Seed of every noise source")->capture_default_str();
    cmd->add_option("--heading-drift", a->o.heading_drift_deg_per_min,
                    "Extra heading drift of the sensor's orientation, deg/min about world +Y")
        ->capture_default_str();
    cmd->add_option("--guided-speed", a->o.guided_speed_deg_s, "Yaw speed of the built-in scan, deg/s")
        ->capture_default_str();
    cmd->add_flag("--hdr-bracket", a->o.hdr_bracket,
                  "After a frame with more than 2 % clipped, add frames at 1/64, 1/4096, ... of its exposure until "
                  "none clips (at most four)");
    cmd->add_option("--threads", a->o.threads, "Render threads (0: all)")->capture_default_str();
    cmd->add_option("--bracket", a->o.bracket,
                    "Instead of a scan: N frames of one still view with the exposure doubling each frame (a "
                    "response-calibration bracket; 0 = a scan)")
        ->capture_default_str();
    cmd->add_option("--bracket-first", a->o.bracket_first_exposure_s, "First exposure of the bracket, seconds")
        ->capture_default_str();
    cmd->add_option("--charuco", a->charuco,
                    "Instead of a scan: N views of a ChArUco board (7x5 squares of 4 cm, DICT_5X5_100) for glint "
                    "calibrate intrinsics; use --size 640x360 or more");
    return {cmd, [a] {
                a->o.env = a->env;
                a->o.out = a->out;
                a->o.camera_noise = !a->no_camera_noise;
                const convolution::Size s = parse_size(a->size, "--size");
                a->o.width = s.width;
                a->o.height = s.height;
                const std::vector<std::string> m = split_list(a->mount, "--mount");
                if (m.size() != 3) throw InputError("--mount needs three angles: yaw,pitch,roll");
                a->o.mount_yaw_deg = parse_number(m[0], "--mount");
                a->o.mount_pitch_deg = parse_number(m[1], "--mount");
                a->o.mount_roll_deg = parse_number(m[2], "--mount");
                if (a->charuco > 0) {
                    const int n = sim::simulate_charuco_session(a->o, a->charuco);
                    std::printf("session %s: %d ChArUco views\n", a->out.c_str(), n);
                    return 0;
                }
                if (a->env.empty()) throw InputError("--env is required (except with --charuco)");
                std::unique_ptr<ProgressBar> bar;
                const sim::SimulateSummary r = sim::simulate_session(a->o, [&](long long d, long long t) {
                    if (!bar) bar = std::make_unique<ProgressBar>("simulate frames", t);
                    (void)d;
                    bar->advance(1);
                });
                if (bar) bar->finish();
                std::printf("session %s: %d frames over %.1f s, %llu sensor bytes (%llu orientations)\n",
                            a->out.c_str(), r.frames, r.duration_s, static_cast<unsigned long long>(r.sensor_bytes),
                            static_cast<unsigned long long>(r.orientation_messages));
                return 0;
            }};
}

Command add_calibrate_command(CLI::App& app) {
    struct Args {
        std::string session, calibration;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand("calibrate", "Camera calibrations from recorded frames, stored in a calibration file");
    cmd->require_subcommand(1);
    CLI::App* response = cmd->add_subcommand(
        "response", "Inverse response curve from an exposure bracket of a still view (OpenCV CalibrateRobertson)");
    response->add_option("--session", a->session, "Session holding the bracket (e.g. glint simulate --bracket 12)")
        ->required();
    response->add_option("--calibration", a->calibration,
                         "Calibration file to update (created from the session's calibration.json when absent)")
        ->required();
    CLI::App* vignetting = cmd->add_subcommand(
        "vignetting", "Vignetting from flat-field frames (a uniformly lit view filling the frame), using the "
                      "calibration's response");
    vignetting->add_option("--session", a->session, "Session holding the flat-field frames")->required();
    vignetting->add_option("--calibration", a->calibration,
                           "Calibration file to update (created from the session's calibration.json when absent)")
        ->required();
    CLI::App* alignment = cmd->add_subcommand(
        "alignment", "Camera-to-sensor rotation and time offset from a scan (rotation-only motion): image rotations "
                     "between consecutive frames against the sensor's");
    alignment->add_option("--session", a->session, "Session of a scan with its sensor recording")->required();
    alignment->add_option("--calibration", a->calibration,
                          "Calibration file to update (created from the session's calibration.json when absent)")
        ->required();
    CLI::App* intrinsics = cmd->add_subcommand(
        "intrinsics", "Focal lengths, principal point and distortion from views of a ChArUco board (7x5 squares of "
                      "4 cm, 3 cm markers, DICT_5X5_100), with the RMS reprojection error");
    intrinsics->add_option("--session", a->session, "Session of board views (e.g. glint simulate --charuco 16)")->required();
    intrinsics->add_option("--calibration", a->calibration,
                           "Calibration file to update (created from the session's calibration.json when absent)")
        ->required();
    return {cmd, [a, vignetting, alignment, intrinsics] {
                const capture::Session s = capture::open_session(a->session);
                if (intrinsics->parsed()) {
                    capture::CameraCalibration cal = std::filesystem::exists(a->calibration)
                                                         ? capture::load_calibration(a->calibration)
                                                         : s.calibration;
                    const capture::IntrinsicsResult r = capture::calibrate_intrinsics(s, {});
                    cal.intrinsics = r.intrinsics;
                    capture::save_calibration(a->calibration, cal);
                    const capture::Intrinsics& k = r.intrinsics;
                    std::printf("intrinsics from %d views (%d corners): fx %.2f fy %.2f cx %.2f cy %.2f k1 %.4f k2 %.4f "
                                "p1 %.5f p2 %.5f k3 %.4f, RMS reprojection %.3f px -> %s\n",
                                r.views, r.corners, k.fx, k.fy, k.cx, k.cy, k.k1, k.k2, k.p1, k.p2, k.k3, r.rms_px,
                                a->calibration.c_str());
                    return 0;
                }
                if (alignment->parsed()) {
                    capture::CameraCalibration cal = std::filesystem::exists(a->calibration)
                                                         ? capture::load_calibration(a->calibration)
                                                         : s.calibration;
                    const capture::AlignmentResult r = capture::calibrate_alignment(s);
                    cal.sensor_from_camera = r.sensor_from_camera;
                    cal.time_offset_s = r.time_offset_s;
                    capture::save_calibration(a->calibration, cal);
                    std::printf("alignment from %d frame pairs: time offset %.3f s, median residual %.3f degrees -> %s\n",
                                r.pairs, r.time_offset_s, r.residual_deg, a->calibration.c_str());
                    if (s.has_truth) {
                        const capture::CameraCalibration truth =
                            capture::load_calibration(s.dir / "truth" / "calibration.json");
                        std::printf("against the session's truth: mounting off by %.3f degrees, time offset by %.1f ms\n",
                                    angle_between(r.sensor_from_camera, truth.sensor_from_camera) * 180 / kPi,
                                    (r.time_offset_s - truth.time_offset_s) * 1e3);
                    }
                    return 0;
                }
                if (vignetting->parsed()) {
                    capture::CameraCalibration cal = std::filesystem::exists(a->calibration)
                                                         ? capture::load_calibration(a->calibration)
                                                         : s.calibration;
                    const capture::VignettingResult r = capture::calibrate_vignetting(s, cal);
                    cal.vignetting = r.vignetting;
                    capture::save_calibration(a->calibration, cal);
                    std::printf("vignetting from %d frames, %lld pixels: a1 %.5f a2 %.5f a3 %.5f, fit RMS %.5f -> %s\n",
                                r.frames, r.pixels, r.vignetting.a1, r.vignetting.a2, r.vignetting.a3, r.fit_rms,
                                a->calibration.c_str());
                    return 0;
                }
                capture::CameraCalibration cal = std::filesystem::exists(a->calibration)
                                                     ? capture::load_calibration(a->calibration)
                                                     : s.calibration;
                const capture::ResponseResult r = capture::calibrate_response(s);
                cal.response = r.response;
                capture::save_calibration(a->calibration, cal);
                std::printf("response from %d frames spanning %.0fx in exposure -> %s\n", r.frames, r.exposure_span,
                            a->calibration.c_str());
                if (s.has_truth) {
                    // Against the session's true curve, as ratios to code 128 (the scale is free), over
                    // codes 64..250: below 64 the simulator's read noise (0.002 of full scale, code 61)
                    // dominates what a code means, and 251..255 are next to clipping.
                    const capture::CameraCalibration truth = capture::load_calibration(s.dir / "truth" / "calibration.json");
                    double worst = 0;
                    for (int z = 64; z <= 250; ++z) {
                        const double est = r.response.inverse[std::size_t(z)] / r.response.inverse[128];
                        const double tru = truth.response.inverse[std::size_t(z)] / truth.response.inverse[128];
                        worst = std::max(worst, std::abs(est / tru - 1));
                    }
                    std::printf("against the session's truth: worst relative error %.2f %% over codes 64..250\n",
                                100 * worst);
                }
                return 0;
            }};
}

Command add_cameras_command(CLI::App& app) {
    CLI::App* cmd = app.add_subcommand("cameras", "List the cameras libcamera finds (exit 1 when there is none)");
    return {cmd, [] {
                const std::vector<std::string> cameras = capture::list_libcamera_cameras();
                if (cameras.empty()) throw RuntimeError("libcamera found no camera");
                for (const std::string& c : cameras) std::printf("%s\n", c.c_str());
                return 0;
            }};
}

Command add_capture_command(CLI::App& app) {
    struct Args {
        capture::CaptureOptions o;
        std::string session, out, size = "1024x512", orientations = "sensors", engine = "cpu";
        bool no_drift = false;
        bool no_adjust = false;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand(
        "capture", "Run the capture pipeline offline on a recorded or simulated session: HDR accumulation on the "
                   "sphere -> environment map (EXR) and its coverage map (<out stem>.coverage.exr)");
    cmd->add_option("--session", a->session, "Session directory (glint simulate, or a recorded one)")->required();
    cmd->add_option("--out", a->out, "Environment map to write (OpenEXR, equirect)")->required();
    cmd->add_option("--size", a->size, "Environment map size WxH")->capture_default_str();
    cmd->add_flag("--no-drift-correction", a->no_drift, "Use the sensor orientations as they are");
    cmd->add_option("--drift-gain", a->o.drift_gain,
                    "Low-pass gain of the drift correction: the share of each new measured offset taken into the "
                    "correction carried to the frames (0..1]")
        ->capture_default_str();
    cmd->add_flag("--no-global-adjustment", a->no_adjust,
                  "Keep the live pass's orientations: no pose graph of frame pairs and the sensor after the scan");
    cmd->add_option("--adjustment-rounds", a->o.adjustment_rounds,
                    "Rounds of the global adjustment: frame pairs aligned again from each solution, then solved")
        ->capture_default_str();
    cmd->add_option("--drift-log", a->o.drift_log,
                    "Write every frame's drift estimate (CSV: index, time, overlapping points, estimate and its "
                    "standard deviation in degrees, residual before and after, applied; on a simulated session also "
                    "the orientation error before and after and the sensor's error vector)");
    cmd->add_option("--orientations-out", a->o.orientations_out,
                    "Write the orientations the map was made with (CSV index,t_ns,w,x,y,z, world_from_camera: the "
                    "format of a simulated session's truth/camera.csv)");
    cmd->add_option("--engine", a->engine, "Accumulation engine: cpu or gpu")->capture_default_str();
    cmd->add_option("--orientations", a->orientations,
                    "sensors (the session's recorded sensor stream) or truth (a simulated session's true "
                    "orientations: isolates the accumulation's own error)")
        ->capture_default_str();
    cmd->add_option("--min-samples", a->o.min_samples, "Frames that must see a texel for it to count as covered")
        ->capture_default_str();
    cmd->add_option("--threads", a->o.threads, "Threads (0: all)")->capture_default_str();
    return {cmd, [a] {
                const convolution::Size s = parse_size(a->size, "--size");
                a->o.width = s.width;
                a->o.height = s.height;
                a->o.session = a->session;
                a->o.out = a->out;
                if (a->orientations == "sensors")
                    a->o.orientations = capture::OrientationInput::Sensors;
                else if (a->orientations == "truth")
                    a->o.orientations = capture::OrientationInput::Truth;
                else
                    throw InputError("--orientations must be sensors or truth");
                if (a->engine != "cpu" && a->engine != "gpu") throw InputError("--engine must be cpu or gpu");
                a->o.drift_correction = !a->no_drift;
                a->o.global_adjustment = !a->no_adjust;
                // The session's frames come from a camera source made by the factory; the
                // simulator's kind is registered here, where the binary's backends are chosen.
                capture::CameraBackends backends = capture::capture_camera_backends();
                sim::add_simulator_camera(backends);
                host::VirtualClock clock;  // offline: frames as fast as they are read
                const std::unique_ptr<capture::CameraSource> camera =
                    capture::make_camera_source("replay:" + a->session, backends, clock);
                // --engine gpu: the accumulation's context, on a surfaceless EGL display.
                std::unique_ptr<gl::EglDisplay> display;
                std::unique_ptr<gl::GlContext> context;
                if (a->engine == "gpu") {
                    display = std::make_unique<gl::EglDisplay>(gl::EglDisplay::surfaceless());
                    context = std::make_unique<gl::GlContext>(*display);
                }
                std::unique_ptr<ProgressBar> bar;
                const auto progress = [&](long long, long long t) {
                    if (!bar) bar = std::make_unique<ProgressBar>(a->o.global_adjustment && a->o.drift_correction
                                                                      ? "accumulate and adjust frames"
                                                                      : "accumulate frames",
                                                                  t);
                    bar->advance(1);
                };
                const capture::CaptureSummary r = capture::run_capture(a->o, *camera, context.get(), progress);
                if (bar) bar->finish();
                if (a->o.drift_correction)
                    std::printf("drift correction: %d of %d frames corrected, median correction %.3f degrees, median "
                                "residual %.4f -> %.4f (RMS log luminance against the sphere)\n",
                                r.drift_applied, r.drift_considered, r.drift_median_deg, r.drift_residual_before,
                                r.drift_residual_after);
                if (a->o.drift_correction && a->o.global_adjustment)
                    std::printf("global adjustment: %d rounds, %d of %d frame pairs aligned in the last, pair error "
                                "%.3f degrees RMS, sensor error %.3f degrees RMS, drift %.3f deg/min, %.1f s\n",
                                a->o.adjustment_rounds, r.adjust_pairs, r.adjust_pairs_tried, r.adjust_pair_rms_deg,
                                r.adjust_sensor_rms_deg, r.adjust_drift_deg_per_min, r.adjust_seconds);
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
                if (r.frames_without_orientation > 0)
                    std::printf("frames without an orientation (skipped): %d\n", r.frames_without_orientation);
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
