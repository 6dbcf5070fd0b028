// `glint simulate`: a recorded capture session with ground truth, rendered from an HDR map
// (appliance/sim; docs/capture.md).
#include <cstdio>
#include <memory>

#include "appliance/app/commands.hpp"
#include "appliance/app/cli_util.hpp"
#include "appliance/capture/charuco.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/progress.hpp"
#include "appliance/core/strict_number.hpp"
#include "appliance/sim/kiosk_simulator.hpp"
#include "appliance/sim/session_simulator.hpp"

namespace glint::app {

Command add_simulate_command(CLI::App& app) {
    struct Args {
        sim::SimulateOptions o;
        std::string env, out, size = "320x180", mount = "2,-1.5,0.5";
        bool no_camera_noise = false;
        int charuco = 0;
        double time_offset_ms = 0;
        bool no_motion_blur = false;
        double readout_ms = capture::kModelledReadoutS * 1e3;
        bool kiosk = false;
        sim::SimulateKioskOptions k;
    };
    auto a = std::make_shared<Args>();
    CLI::App* cmd = app.add_subcommand("simulate", std::string(command_summary("simulate").summary));
    cmd->add_option("--env", a->env, "Equirect HDR environment map (OpenEXR); not with --charuco");
    cmd->add_option("--trajectory", a->o.trajectory,
                    "guided (the built-in scan: rings at -60..60 degrees and the zenith, ~52 s), alignment (the "
                    "calibration motion for glint calibrate alignment: +-25 degree sweeps about yaw, pitch and roll "
                    "in turn, ~19 s) or a file of "
                    "lines t_seconds,w,x,y,z (camera-to-world, conventions' frame)")
        ->capture_default_str();
    cmd->add_option("--out", a->out, "Session directory to create")->required();
    cmd->add_flag("--force", a->o.overwrite, "Replace an existing session directory");
    cmd->add_option("--fps", a->o.fps, "Frames per second")->capture_default_str();
    cmd->add_option("--size", a->size, "Frame size WxH, pixels")->check(size_validator())->capture_default_str();
    cmd->add_option("--fov", a->o.horizontal_fov_deg, "Horizontal field of view, degrees")->capture_default_str();
    cmd->add_option("--imu", a->o.imu, "Sensor board IMU: raw (MPU-6050 + QMC5883L, fused on the board) or bno055")
        ->check(CLI::IsMember({"raw", "bno055"}))
        ->capture_default_str();
    cmd->add_option("--sensor-noise", a->o.sensor_noise, "Sensor error preset: none, default, high")
        ->check(CLI::IsMember({"none", "default", "high"}))
        ->capture_default_str();
    cmd->add_flag("--no-camera-noise", a->no_camera_noise, "Render without shot and read noise");
    cmd->add_option("--camera-full-well", a->o.camera_full_well_electrons,
                    "Camera sensor's photo-electrons at relative exposure 1 and gain 1 (shot noise; a smaller full "
                    "well also reads the same light brighter)")
        ->check(CLI::Range(100.0, 1e7))
        ->capture_default_str();
    cmd->add_option("--camera-read-noise", a->o.camera_read_noise,
                    "Camera sensor's read noise, standard deviation in relative exposure")
        ->check(CLI::Range(0.0, 0.1))
        ->capture_default_str();
    cmd->add_option("--mount", a->mount, "Sensor mounting error yaw,pitch,roll in degrees (sensor_from_camera)")
        ->capture_default_str();
    cmd->add_option("--clock-drift-ppm", a->o.clock_drift_ppm, "Board clock rate error against the appliance clock")
        ->capture_default_str();
    cmd->add_option("--time-offset-ms", a->time_offset_ms,
                    "Camera-sensor time offset, ms (camera timestamp + offset = sensor time of the same instant)")
        ->capture_default_str();
    cmd->add_option("--seed", a->o.seed, "Seed of every noise source")->capture_default_str();
    cmd->add_option("--heading-drift", a->o.heading_drift_deg_per_min,
                    "Extra heading drift of the sensor's orientation, deg/min about world +Y")
        ->capture_default_str();
    cmd->add_option("--guided-speed", a->o.guided_speed_deg_s, "Yaw speed of the built-in scan, deg/s")
        ->capture_default_str();
    cmd->add_flag("--hdr-bracket", a->o.hdr_bracket,
                  "Record what the capture pipeline's exposure controller asks for: after a frame with any pixel "
                  "clipped, frames 2 ms apart at 1/64, 1/4096, ... of its exposure x gain until none clips (at "
                  "most four, none shorter than the sensor's shortest exposure), a top-up frame where the last reads a "
                  "compact source low (--top-up-below), then auto-exposure again");
    cmd->add_option("--control-delay", a->o.control_delay_frames,
                    "With --hdr-bracket: frames an exposure request takes to apply (a real camera's 2-3); 0 = "
                    "the next frame. The frames in between are recorded too")
        ->capture_default_str();
    cmd->add_option("--top-up-below", a->o.top_up_below,
                    "With --hdr-bracket: when a bracket's last frame reads its brightest pixel under this share of "
                    "the range, one more frame exposed towards half of it, at least a band below the step that clipped (4x the "
                    "last step; docs/capture.md \"Exposure control\"; "
                    "the controller's default; 0 = none)")
        ->capture_default_str();
    cmd->add_flag("--sensor-limits", a->o.sensor_limits,
                  "Model the sensor's shortest exposure (20 us) and the lens's glare (2 % in 1 degree), and write "
                  "them to the session's calibration; sources still clipped at the shortest exposure are then "
                  "estimated by glint capture (not reliable yet: docs/capture.md)");
    cmd->add_flag("--no-motion-blur", a->no_motion_blur,
                  "Render each frame at its rows' mid-exposure orientations instead of integrating every pixel over "
                  "its exposure along the trajectory");
    cmd->add_option("--readout-ms", a->readout_ms,
                    "Rolling shutter: time to read the rows out top to bottom, ms (written to the session's "
                    "calibration as readout_s; 0 = a global shutter; default: a Pi camera v2 in its 1080p mode)")
        ->capture_default_str();
    cmd->add_option("--threads", a->o.threads, "Render threads; 0 = all cores")
        ->check(non_negative_number())
        ->capture_default_str();
    cmd->add_option("--bracket", a->o.bracket,
                    "Instead of a scan: N frames of one still view with the exposure doubling each frame (a "
                    "response-calibration bracket; 0 = a scan)")
        ->capture_default_str();
    cmd->add_option("--bracket-first", a->o.bracket_first_exposure_s, "First exposure of the bracket, seconds")
        ->capture_default_str();
    cmd->add_flag("--kiosk", a->kiosk,
                  "Instead of a scan: a kiosk session for glint replay (docs/capture.md \"Kiosk sessions\"): 3 s of "
                  "attract looking at the marker board on the table, a button press, the guided scan as the "
                  "capture benchmark takes it (35 deg/s, 3 fps, --hdr-bracket, 1 deg/min of heading drift), then "
                  "12 s of AR at 12 fps walking round the board, hidden once for 0.3 s by an arm passing in front; writes events.csv, "
                  "kiosk.json and truth/board.csv besides the session's files. With --env, --out, --seed, --no-camera-noise, "
                  "--threads, --force, and for measurements --size (default 320x180), --frame-format, "
                  "--jpeg-quality");
    cmd->add_option("--frame-format", a->k.frame_format, "With --kiosk: frames as jpg or png")
        ->check(CLI::IsMember({"jpg", "png"}))
        ->capture_default_str();
    cmd->add_option("--jpeg-quality", a->k.jpeg_quality, "With --kiosk: JPEG quality of the frames, 1..100")
        ->check(CLI::Range(1, 100))
        ->capture_default_str();
    cmd->add_option("--charuco", a->charuco,
                    "Instead of a scan: N views of a ChArUco board (7x5 squares of 4 cm, DICT_5X5_100) for glint "
                    "calibrate intrinsics; use --size 640x360 or more");
    const auto run_kiosk = [](const CLI::App& c, Args& args) {
        // The kiosk session fixes its own trajectory, rates, brackets and camera: a flag of the
        // scan's would be silently ignored, so it is refused.
        for (const char* flag : {"--trajectory", "--fps", "--fov", "--imu", "--sensor-noise", "--mount", "--clock-drift-ppm",
                                 "--time-offset-ms", "--heading-drift", "--guided-speed", "--hdr-bracket",
                                 "--control-delay", "--top-up-below", "--sensor-limits", "--no-motion-blur", "--readout-ms", "--bracket",
                                 "--bracket-first", "--charuco"})
            if (c.count(flag) > 0) throw InputError(std::string(flag) + " does not apply with --kiosk");
        sim::SimulateKioskOptions& k = args.k;
        k.env = args.env;
        k.out = args.out;
        k.overwrite = args.o.overwrite;
        k.on_environment = [&](const LoadedExr& loaded) { warn_about_environment(args.env, loaded); };
        k.seed = args.o.seed;
        k.threads = args.o.threads;
        k.camera_noise = args.o.camera_noise;
        if (c.count("--size") > 0) {
            k.width = args.o.width;
            k.height = args.o.height;
        }
        std::unique_ptr<ProgressBar> bar;
        const sim::KioskSummary r = sim::simulate_kiosk_session(k, [&](long long d, long long t) {
            if (!bar) bar = std::make_unique<ProgressBar>("simulate kiosk frames", t);
            (void)d;
            bar->advance(1);
        });
        if (bar) bar->finish();
        std::printf("kiosk session %s: %d frames over %.1f s (attract %d, scan %d with brackets, AR %d), %llu sensor "
                    "bytes; the board hidden %.2f-%.2f s (t_ns %lld-%lld, an arm at %.2f m/s); irradiance on the table "
                    "%.4g %.4g %.4g\n",
                    args.out.c_str(), r.session.frames, r.session.duration_s, r.attract_frames, r.scan_frames,
                    r.ar_frames, static_cast<unsigned long long>(r.session.sensor_bytes), r.dropout_start_s,
                    r.dropout_end_s, static_cast<long long>(r.dropout_start_ns),
                    static_cast<long long>(r.dropout_end_ns), r.sleeve_speed_m_s, r.irradiance_up[0], r.irradiance_up[1], r.irradiance_up[2]);
        return 0;
    };
    return {cmd, [a, cmd, run_kiosk] {
                a->o.env = a->env;
                a->o.out = a->out;
                a->o.camera_noise = !a->no_camera_noise;
                a->o.time_offset_s = a->time_offset_ms * 1e-3;
                a->o.motion_blur = !a->no_motion_blur;
                a->o.readout_s = a->readout_ms * 1e-3;
                const convolution::Size s = parse_size(a->size, "--size");
                a->o.width = s.width;
                a->o.height = s.height;
                const std::vector<std::string> m = split_list(a->mount, "--mount");
                if (m.size() != 3) throw InputError("--mount needs three angles: yaw,pitch,roll");
                a->o.mount_yaw_deg = parse_double(m[0], "--mount");
                a->o.mount_pitch_deg = parse_double(m[1], "--mount");
                a->o.mount_roll_deg = parse_double(m[2], "--mount");
                if (a->kiosk && a->charuco > 0) throw InputError("--charuco does not apply with --kiosk");
                for (const char* flag : {"--frame-format", "--jpeg-quality"})
                    if (!a->kiosk && cmd->count(flag) > 0) throw InputError(std::string(flag) + " needs --kiosk");
                if (cmd->count("--top-up-below") > 0 && !a->o.hdr_bracket)
                    throw InputError("--top-up-below needs --hdr-bracket");
                if (a->charuco > 0) {
                    const int n = sim::simulate_charuco_session(a->o, a->charuco);
                    std::printf("session %s: %d ChArUco views\n", a->out.c_str(), n);
                    return 0;
                }
                if (a->env.empty()) throw InputError("--env is required (except with --charuco)");
                if (a->kiosk) return run_kiosk(*cmd, *a);
                a->o.on_environment = [&](const LoadedExr& loaded) { warn_about_environment(a->env, loaded); };
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

}  // namespace glint::app
