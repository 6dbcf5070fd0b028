#include "appliance/sim/session_simulator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <fstream>
#include <optional>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "appliance/capture/calibration_io.hpp"
#include "appliance/capture/charuco.hpp"
#include "appliance/capture/exposure_controller.hpp"
#include "appliance/capture/session.hpp"
#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/parallel.hpp"
#include "appliance/sim/camera_simulator.hpp"
#include "appliance/sim/session_writer.hpp"
#include "firmware_bridge/firmware/sim/sim_board.hpp"
#include "firmware_bridge/firmware/sim/sim_hal.hpp"
#include "firmware_bridge/host/orientation_history.hpp"
#include "firmware_bridge/protocol/frame_decoder.hpp"
#include "firmware_bridge/recording/clock.hpp"
#include "firmware_bridge/recording/recorder.hpp"

namespace glint::sim {

namespace fs = std::filesystem;
using capture::CameraCalibration;
using capture::CameraFrame;
using capture::Intrinsics;
using firmware::sim::TrajectorySample;

namespace {

constexpr double kDeg = kPi / 180.0;
// The board boots (the BNO055 is silent for 650 ms) before the camera's first frame.
constexpr std::uint64_t kLeadUs = 1'000'000;
// Appliance clock at board reset, µs (any value; not 0 so that a mix-up of clocks shows).
constexpr std::uint64_t kHostAtBoardResetUs = 5'000'000'000ULL;

void write_text(const fs::path& p, const std::string& text) {
    std::ofstream out(p);
    out << text;
    if (!out.flush()) throw RuntimeError(p.string() + ": cannot write");
}

// camera_look on the trajectory side, in the firmware simulator's maths: its yaw, pitch, roll
// with the roll turned round (it rolls about +Z).
firmware::Quatd look(double yaw_deg, double pitch_deg, double roll_deg = 0) {
    return firmware::normalized(firmware::sim::quat_from_ypr_deg(yaw_deg, pitch_deg, -roll_deg));
}

// The simulator's edge: trajectories (the board's and the camera's) are the firmware
// simulator's; what the camera renders and the truth it writes are the appliance's.
glm::dquat world_from_camera_at(const firmware::sim::Trajectory& camera, std::uint64_t t_us) {
    return host::to_glm(camera.at(t_us).world_from_sensor);
}

// The camera's path around camera time t_us, as an offset in seconds (what render() integrates
// a frame's rows and exposures over).
CameraPath camera_path(const firmware::sim::Trajectory& camera, std::uint64_t t_us) {
    return [&camera, t_us](double offset_s) {
        const double t = double(t_us) + offset_s * 1e6;
        return world_from_camera_at(camera, t <= 0 ? 0 : std::uint64_t(std::llround(t)));
    };
}

// Frames of a scan along `camera` at `fps`, the first at its time 0.
int scan_frames(const firmware::sim::Trajectory& camera, double fps) {
    return int(std::floor(double(camera.end_us()) * 1e-6 * fps)) + 1;
}

// Appliance time of a board instant: the board clock runs clock_drift_ppm fast.
std::uint64_t host_us_of_board(const SimulateOptions& o, std::uint64_t board_us) {
    const double rate = 1.0 + o.clock_drift_ppm * 1e-6;
    return kHostAtBoardResetUs + std::uint64_t(std::llround(double(board_us) / rate));
}

// The true camera: a mild lens, vignetting, a gamma-like response, the sensor mounted with a
// small error that calibration is supposed to find.
CameraCalibration true_camera(const SimulateOptions& o, const SensorModel& sensor) {
    CameraCalibration truth;
    truth.intrinsics = Intrinsics::from_fov(o.width, o.height, o.horizontal_fov_deg * kDeg);
    truth.intrinsics.k1 = -0.08;
    truth.intrinsics.k2 = 0.012;
    truth.vignetting = {-0.22, 0.03, 0};
    truth.sensor_from_camera = host::to_glm(look(o.mount_yaw_deg, o.mount_pitch_deg, o.mount_roll_deg));
    truth.sensitivity = sensor.electrons_per_radiance_second / sensor.full_well_electrons;
    truth.time_offset_s = o.time_offset_s;
    truth.readout_s = o.readout_s;
    if (sensor.noise) {
        truth.noise_full_well_electrons = sensor.full_well_electrons;
        truth.noise_read = sensor.read_noise;
    }
    if (o.sensor_limits) {
        truth.min_exposure_s = capture::kModelledMinExposureS;
        truth.glare_fraction = capture::kModelledGlareFraction;
        truth.glare_sigma_rad = capture::kModelledGlareSigmaRad;
    }
    return truth;
}

}  // namespace

glm::dquat camera_look(double yaw_deg, double pitch_deg, double roll_deg) {
    return host::to_glm(look(yaw_deg, pitch_deg, roll_deg));
}

std::vector<TrajectorySample> guided_camera_trajectory(double speed_deg_s) {
    std::vector<TrajectorySample> out;
    const double step_s = 0.01;
    double t = 0;
    const auto add = [&](double yaw, double pitch) {
        out.push_back({std::uint64_t(std::llround(t * 1e6)), look(yaw, pitch)});
        t += step_s;
    };
    const double rings[] = {-60, -30, 0, 30, 60};
    const double speed = speed_deg_s;
    double yaw = 0;
    bool forward = true;
    for (std::size_t r = 0; r < std::size(rings); ++r) {
        const double pitch = rings[r];
        const int steps = int(360 / speed / step_s);
        for (int k = 0; k < steps; ++k) add(yaw + (forward ? 1 : -1) * 360.0 * k / steps, pitch);
        yaw += forward ? 360 : -360;
        const double next = r + 1 < std::size(rings) ? rings[r + 1] : 85.0;
        const int move = int(1.5 / step_s);
        for (int k = 0; k < move; ++k) add(yaw, pitch + (next - pitch) * (0.5 - 0.5 * std::cos(kPi * k / move)));
        forward = !forward;
    }
    const int steps = int(4.0 / step_s);
    for (int k = 0; k <= steps; ++k) add(yaw + (forward ? 1 : -1) * 360.0 * k / steps, 85);
    return out;
}

std::vector<TrajectorySample> alignment_camera_trajectory(double amplitude_deg, double period_s, int cycles) {
    std::vector<TrajectorySample> out;
    const double step_s = 0.01;
    double t = 0;
    const auto add = [&](double yaw, double pitch, double roll) {
        out.push_back({std::uint64_t(std::llround(t * 1e6)), look(yaw, pitch, roll)});
        t += step_s;
    };
    // Still at the horizon first (the board settles), then yaw, pitch and roll in turn: sinusoidal
    // sweeps (the speed changes all the time, which is what makes the time offset observable),
    // each axis back at 0 before the next, and a short still at the end.
    const int hold = int(0.5 / step_s);
    for (int k = 0; k < hold; ++k) add(0, 0, 0);
    const int steps = int(std::lround(cycles * period_s / step_s));
    for (int axis = 0; axis < 3; ++axis) {
        for (int k = 0; k < steps; ++k) {
            const double a = amplitude_deg * std::sin(2 * kPi * k * step_s / period_s);
            add(axis == 0 ? a : 0, axis == 1 ? a : 0, axis == 2 ? a : 0);
        }
    }
    for (int k = 0; k <= hold; ++k) add(0, 0, 0);
    return out;
}

namespace {

SimulateSummary write_session(const SimulateOptions& o, const HdrImage& env, const detail::SessionPlan& plan,
                              const fs::path& partial, const std::function<void(long long, long long)>& progress) {
    const firmware::sim::Trajectory& camera = *plan.camera;
    const double duration_s = double(camera.end_us()) * 1e-6;
    SensorModel sensor;
    sensor.noise = o.camera_noise;
    sensor.motion_blur = o.motion_blur;
    sensor.full_well_electrons = o.camera_full_well_electrons;
    sensor.read_noise = o.camera_read_noise;
    const CameraCalibration truth = true_camera(o, sensor);

    // The sensor board rides on the camera: world_from_sensor = world_from_camera * camera_from_sensor,
    // held still for the board's boot (kLeadUs) before the camera's time 0.
    const firmware::Quatd camera_from_sensor = look(o.mount_yaw_deg, o.mount_pitch_deg, o.mount_roll_deg).conj();
    std::vector<TrajectorySample> sensor_path;
    for (std::uint64_t b = 0; b <= kLeadUs + camera.end_us() + 500'000; b += 5'000) {
        const std::uint64_t tc = b > kLeadUs ? b - kLeadUs : 0;
        const firmware::Quatd drift =
            firmware::Quatd::from_axis_angle({0, 1, 0}, o.heading_drift_deg_per_min * kDeg * double(b) / 60e6);
        sensor_path.push_back({b, firmware::normalized(drift * camera.at(tc).world_from_sensor * camera_from_sensor)});
    }
    const firmware::sim::Trajectory sensor_trajectory(sensor_path);

    const auto host_us = [&](std::uint64_t board_us) { return host_us_of_board(o, board_us); };

    // --- the orientation stream, recorded as the serial driver records a live board ---
    firmware::sim::SimBoardOptions board;
    board.imu = o.imu == "raw" ? firmware::sim::ImuKind::Raw : firmware::sim::ImuKind::Bno055;
    board.seed = o.seed;
    if (o.sensor_noise == "none") board.errors = firmware::sim::SensorErrors::none();
    if (o.sensor_noise == "high") {
        board.errors.gyro_noise_rad_s *= 5;
        board.errors.accel_noise_m_s2 *= 5;
        board.errors.mag_noise_ut *= 5;
    }
    firmware::sim::MemoryUart uart;
    firmware::sim::VirtualClock board_clock;
    firmware::sim::SimBoard sim_board(sensor_trajectory, board, uart, board_clock);
    recording::RecorderOptions ropt;
    ropt.header.transport = recording::Transport::Simulator;
    ropt.header.baud = 921600;
    ropt.header.device = "glint simulate (" + o.imu + " board)";
    ropt.header.decoded_types = recording::board_message_types();
    ropt.header.created_unix_us = 1'795'000'000'000'000;  // fixed: same options, same file
    ropt.header.created_monotonic_us = kHostAtBoardResetUs;
    ropt.header.notes = {{"generator", plan.created_by}, {"imu", o.imu}, {"sensor_noise", o.sensor_noise}};
    recording::VirtualClock record_clock(kHostAtBoardResetUs);
    SimulateSummary summary;
    {
        recording::Recorder recorder((partial / "sensors.glrec").string(), ropt, record_clock);
        protocol::FrameDecoder decoder;
        sim_board.start();
        const std::uint64_t end_board = kLeadUs + camera.end_us() + 500'000;
        while (board_clock.now_us() < end_board) {
            sim_board.poll();
            const std::uint64_t sent_board_us = board_clock.now_us();  // the pass's end: its bytes leave
            sim_board.idle();
            std::vector<std::uint8_t> bytes = uart.take();
            if (bytes.empty()) continue;
            // Delivered after the line time of the bytes (10 bits each at 921600 bit/s, 10.9 us)
            // plus 0.3 ms of USB latency.
            const std::uint64_t t = host_us(sent_board_us) + 300 + bytes.size() * 10'000'000 / 921'600;
            record_clock.sleep_until_us(t);
            recorder.on_bytes(t, bytes);
            decoder.feed_all(bytes, [&](const protocol::FrameEvent& e) {
                recorder.on_sample(t, e);
                if (e.status == protocol::FrameStatus::Ok && e.type == std::uint8_t(protocol::MessageType::Orientation))
                    ++summary.orientation_messages;
            });
            summary.sensor_bytes += bytes.size();
        }
        if (!recorder.close()) throw RuntimeError(recorder.error());
    }

    // --- the frames ---
    AutoExposureModel ae;
    ae.enabled = o.bracket == 0;
    CameraSimulator cam(env, truth, sensor, ae, o.seed);
    const int threads = o.threads > 0 ? o.threads : hardware_threads();
    long long total_frames = 0;
    for (const detail::SessionSegment& segment : plan.segments) total_frames += o.bracket > 0 ? o.bracket : segment.frames;
    std::string frames_csv = capture::frames_csv_header() + "\n";
    std::string truth_csv = capture::camera_poses_csv_header() + "\n";
    std::vector<detail::WrittenFrame> written_frames;
    int written = 0;
    int segment_index = 0;  // the segment being taken
    const bool jpeg = o.frame_format == "jpg";
    const std::vector<int> write_params =
        jpeg ? std::vector<int>{cv::IMWRITE_JPEG_QUALITY, o.jpeg_quality} : std::vector<int>{};
    const auto emit = [&](const CameraFrame& f, const glm::dquat& q, std::int64_t t_ns, std::uint64_t tc_us) {
        char name[32];
        std::snprintf(name, sizeof name, jpeg ? "frames/%06d.jpg" : "frames/%06d.png", written);
        cv::Mat bgr;
        cv::cvtColor(f.rgb, bgr, cv::COLOR_RGB2BGR);
        if (!cv::imwrite((partial / name).string(), bgr, write_params))
            throw RuntimeError((partial / name).string() + ": cannot write");
        const capture::FrameRecord record{std::uint64_t(written), t_ns, f.exposure_s, f.analogue_gain,
                                          f.digital_gain, name};
        frames_csv += capture::frames_csv_line(record) + "\n";
        truth_csv += capture::camera_poses_csv_line({std::uint64_t(written), t_ns, q}) + "\n";
        written_frames.push_back({std::uint64_t(written), t_ns, tc_us, segment_index, q});
        ++written;
    };
    // With --hdr-bracket the capture pipeline's exposure controller decides the brackets
    // (capture/exposure_controller.hpp, default settings, the true shortest exposure), and the
    // camera does what it asks `control_delay_frames` frames later. The requests reach the
    // renderer's exposure (set_exposure(exposure, gain)), not its CameraSource face: a camera's
    // auto-exposure keeps its own state while a manual exposure is in force and resumes from it,
    // which is what the sessions have recorded since --hdr-bracket exists, while
    // CameraSimulator::set_exposure(ExposureRequest) resumes from the bracket's exposure.
    std::optional<capture::ExposureController> controller;  // in the segments with hdr_bracket
    struct PendingRequest {
        long long from_frame;  // applies to the frame of this index (frames rendered so far) and later
        capture::ExposureRequest request;
    };
    std::deque<PendingRequest> pending;
    long long rendered = 0;
    bool manual = false;  // a manual request is in force
    double manual_exposure_s = 0, manual_gain = 1;
    double resume_exposure_s = 0, resume_gain = 1;  // where the auto-exposure loop goes on from
    const auto apply = [&](const capture::ExposureRequest& r) {
        if (r.automatic) {
            if (manual) cam.set_exposure(resume_exposure_s, resume_gain);
            manual = false;
            return;
        }
        if (!manual) {
            resume_exposure_s = cam.exposure_s();
            resume_gain = cam.gain();
        }
        manual = true;
        manual_exposure_s = r.exposure_s;
        manual_gain = r.analogue_gain;
    };
    // One frame: rendered, written, shown to the controller; its requests queued, those due
    // applied, and a manual exposure held (render() let the auto-exposure loop move it).
    // q: the true orientation at the frame's time (written as truth); tc_us: that time on the
    // trajectory, along which the frame is rendered (motion blur, rolling shutter; a
    // calibration bracket is one still view).
    // The segment's local scene is seen from its camera position around the frame's time.
    const detail::SessionSegment* segment = nullptr;
    const auto take = [&](const glm::dquat& q, std::uint64_t tc_us, std::int64_t t_ns) {
        CameraFrame f;
        if (o.bracket > 0) {
            f = cam.render(q, t_ns, threads);
        } else if (segment->scene) {
            const double t_s = double(tc_us) * 1e-6;
            const LocalView local{segment->scene,
                                  [segment, t_s](double offset_s) { return segment->position(t_s + offset_s); }, t_s};
            f = cam.render(camera_path(camera, tc_us), local, t_ns, threads);
        } else {
            f = cam.render(camera_path(camera, tc_us), t_ns, threads);
        }
        ++rendered;
        emit(f, q, t_ns, tc_us);
        if (!controller) return;
        if (const auto r = controller->on_frame(f)) pending.push_back({rendered + o.control_delay_frames, *r});
        while (!pending.empty() && pending.front().from_frame <= rendered) {
            apply(pending.front().request);
            pending.pop_front();
        }
        if (manual) cam.set_exposure(manual_exposure_s, manual_gain);
    };
    // The sensor's appliance time of the instant camera time tc shows, minus the time offset:
    // camera timestamp + time_offset_s = sensor time (conventions.md, "Camera frame").
    const auto frame_t_ns = [&](std::uint64_t tc) {
        return std::int64_t(host_us(kLeadUs + tc)) * 1000 - std::int64_t(std::llround(o.time_offset_s * 1e9));
    };
    const auto frame_tc = [&](const detail::SessionSegment& s, int k) {
        return s.start_us + std::uint64_t(std::llround(k / s.fps * 1e6));
    };
    long long done = 0;
    for (std::size_t si = 0; si < plan.segments.size(); ++si) {
        segment = &plan.segments[si];
        segment_index = int(si);
        pending.clear();
        controller.reset();
        if (segment->hdr_bracket) {
            capture::ExposureControlSettings settings;
            settings.min_exposure_s = truth.min_exposure_s;
            settings.code_exposure = truth.response.inverse;  // the camera's response (top-up frames)
            settings.top_up_below = o.top_up_below;
            controller.emplace(settings);
        }
        const int frames = o.bracket > 0 ? o.bracket : segment->frames;
        for (int k = 0; k < frames; ++k) {
            const std::uint64_t tc = o.bracket > 0 ? 0 : frame_tc(*segment, k);
            // A bracket of the built-in scan looks at the horizon (the scan itself starts at the floor).
            const glm::dquat q =
                o.bracket > 0 && o.trajectory == "guided" ? camera_look(0, 0) : world_from_camera_at(camera, tc);
            if (o.bracket > 0) cam.set_exposure(o.bracket_first_exposure_s * std::pow(2.0, k), 1.0);
            // A calibration bracket looks at one still view (tc = 0) but its frames are still taken
            // one after another at the frame rate.
            const std::int64_t t_ns = frame_t_ns(frame_tc(*segment, k));
            take(q, tc, t_ns);
            // While the controller brackets (waits for a requested exposure or takes the next), the
            // camera takes frames as fast as it can: one readout time apart (a rolling shutter cannot
            // start reading the next frame before the last is read; 2 ms for a global shutter), a
            // burst that sees nearly its first frame's view; the next frame comes when the burst
            // would reach its time (times must increase).
            const std::int64_t burst_ns = std::max<std::int64_t>(2'000'000, std::llround(truth.readout_s * 1e9));
            const std::int64_t next_t_ns = k + 1 < frames                    ? frame_t_ns(frame_tc(*segment, k + 1))
                                           : si + 1 < plan.segments.size() ? frame_t_ns(plan.segments[si + 1].start_us)
                                                                            : INT64_MAX;
            for (int b = 1; controller && controller->bracketing(); ++b) {
                const std::int64_t tb_ns = t_ns + std::int64_t(b) * burst_ns;
                if (tb_ns >= next_t_ns) break;
                const std::uint64_t tb = tc + std::uint64_t(b) * std::uint64_t(burst_ns / 1000);
                take(world_from_camera_at(camera, tb), tb, tb_ns);
            }
            if (progress) progress(++done, total_frames);
        }
        // The next segment starts under auto-exposure, from where the loop was before any bracket.
        if (manual) apply(capture::ExposureRequest{});
    }
    write_text(partial / "frames.csv", frames_csv);
    write_text(partial / "truth" / "camera.csv", truth_csv);
    capture::save_calibration(partial / "calibration.json", truth);
    capture::save_calibration(partial / "truth" / "calibration.json", truth);
    if (plan.env_file.empty()) save_exr(partial / "truth" / "env.exr", env);
    else fs::copy_file(plan.env_file, partial / "truth" / "env.exr");
    write_text(partial / "session.json", capture::session_json(plan.created_by));
    if (plan.finish) plan.finish(partial, written_frames);
    if (fs::exists(o.out)) fs::remove_all(o.out);
    fs::rename(partial, o.out);
    summary.frames = written;
    summary.duration_s = duration_s;
    return summary;
}

}  // namespace

namespace {
// `out` may be written: it does not exist, or --force is given and it is a session (session.json
// in it) or an empty directory. --force removed whatever was there (a directory of the user's
// files, a file) when the session was written.
void check_replaceable(const fs::path& out, bool overwrite) {
    std::error_code ec;
    if (!fs::exists(out, ec)) return;
    if (!overwrite) throw InputError(out.string() + ": already exists (give --force to replace it)");
    const bool session = fs::is_directory(out, ec) && fs::is_regular_file(out / "session.json", ec);
    const bool empty = fs::is_directory(out, ec) && fs::is_empty(out, ec);
    if (!session && !empty)
        throw InputError(out.string() + ": not a session (no session.json in it); --force replaces a session "
                         "directory only, never other files");
}
}  // namespace

void detail::check_common_options(const SimulateOptions& o) {
    if (o.width < 16 || o.height < 16 || o.width > 8192 || o.height > 8192)
        throw InputError("--size must be between 16x16 and 8192x8192");
    if (!(std::abs(o.time_offset_s) <= 1.0)) throw InputError("--time-offset-ms must be in [-1000, 1000]");
    if (!(o.readout_s >= 0 && o.readout_s < 1.0)) throw InputError("--readout-ms must be in [0, 1000)");
    if (!(o.horizontal_fov_deg > 5 && o.horizontal_fov_deg < 150)) throw InputError("--fov must be in (5, 150) degrees");
    if (o.imu != "raw" && o.imu != "bno055") throw InputError("--imu must be raw or bno055");
    if (o.sensor_noise != "none" && o.sensor_noise != "default" && o.sensor_noise != "high")
        throw InputError("--sensor-noise must be none, default or high");
    if (o.frame_format != "png" && o.frame_format != "jpg") throw InputError("frame format must be png or jpg");
    if (o.jpeg_quality < 1 || o.jpeg_quality > 100) throw InputError("JPEG quality must be in 1..100");
    check_replaceable(o.out, o.overwrite);
}

void detail::check_session_length(const firmware::sim::Trajectory& camera, const std::string& where) {
    if (camera.end_us() == 0) throw InputError(where + "the trajectory must last longer than 0 s");
    const double seconds = double(camera.end_us()) * 1e-6;
    if (seconds > kMaxSessionS)
        throw InputError(where + "the trajectory lasts " + std::to_string(std::llround(seconds)) +
                         " s; a simulated session lasts at most " + std::to_string(int(kMaxSessionS)) + " s");
}

std::int64_t detail::appliance_time_ns(const SimulateOptions& o, std::uint64_t camera_us) {
    return std::int64_t(host_us_of_board(o, kLeadUs + camera_us)) * 1000;
}

capture::CameraCalibration detail::true_camera(const SimulateOptions& o) { return sim::true_camera(o, SensorModel{}); }

SimulateSummary detail::write_planned_session(const SimulateOptions& o, const HdrImage& env, const SessionPlan& plan,
                                              const std::function<void(long long, long long)>& progress) {
    if (!plan.camera) throw InputError("the trajectory must last longer than 0 s");
    check_session_length(*plan.camera, "");
    for (std::size_t i = 0; i < plan.segments.size(); ++i) {
        const SessionSegment& s = plan.segments[i];
        if (!(s.fps > 0 && s.fps <= 120)) throw InputError("a segment's frame rate must be in (0, 120] fps");
        if (s.scene && !s.position) throw InputError("a segment with a local scene needs the camera's position");
        if (i > 0 && s.start_us <= plan.segments[i - 1].start_us) throw InputError("segments must be in time order");
    }
    const fs::path partial = o.out.string() + ".partial";
    fs::remove_all(partial);
    fs::create_directories(partial / "frames");
    fs::create_directories(partial / "truth");
    try {
        return write_session(o, env, plan, partial, progress);
    } catch (...) {
        std::error_code ignored;
        fs::remove_all(partial, ignored);  // never leave half a session behind
        throw;
    }
}

SimulateSummary simulate_session(const SimulateOptions& o, const std::function<void(long long, long long)>& progress) {
    if (!(o.fps > 0 && o.fps <= 120)) throw InputError("--fps must be in (0, 120]");
    if (o.bracket < 0 || o.bracket > 30) throw InputError("--bracket must be in [0, 30] frames");
    if (o.control_delay_frames < 0 || o.control_delay_frames > 30)
        throw InputError("--control-delay must be in [0, 30] frames");
    if (o.control_delay_frames > 0 && !o.hdr_bracket) throw InputError("--control-delay needs --hdr-bracket");
    // The controller's own bound (top_up_below < top_up_target), checked before anything is written.
    const double top_up_target = capture::ExposureControlSettings{}.top_up_target;
    if (!(o.top_up_below >= 0 && o.top_up_below < top_up_target)) {
        char bound[32];
        std::snprintf(bound, sizeof bound, "%g", top_up_target);
        throw InputError(std::string("--top-up-below must be 0 (no top-up frames) or a share of the range under ") + bound);
    }
    if (!(o.guided_speed_deg_s >= 5 && o.guided_speed_deg_s <= 180)) throw InputError("--guided-speed must be 5..180 deg/s");
    if (o.bracket > 0 && !(o.bracket_first_exposure_s > 0)) throw InputError("--bracket-first must be positive");
    // What frames.csv may hold (session.hpp), checked before anything is written: --bracket 21
    // from the default 1e-4 s went past 100 s, and the session would not have opened.
    if (o.bracket > 0 && (o.bracket_first_exposure_s < capture::kMinFrameExposureS ||
                          o.bracket_first_exposure_s * std::pow(2.0, o.bracket - 1) > capture::kMaxFrameExposureS)) {
        char range[160];
        std::snprintf(range, sizeof range, "--bracket %d from --bracket-first %g s reaches %g s; a frame's exposure must be %g to %g s",
                      o.bracket, o.bracket_first_exposure_s, o.bracket_first_exposure_s * std::pow(2.0, o.bracket - 1),
                      capture::kMinFrameExposureS, capture::kMaxFrameExposureS);
        throw InputError(range);
    }
    detail::check_common_options(o);
    const firmware::sim::Trajectory camera = [&] {
        if (o.trajectory == "guided") return firmware::sim::Trajectory(guided_camera_trajectory(o.guided_speed_deg_s));
        if (o.trajectory == "alignment") return firmware::sim::Trajectory(alignment_camera_trajectory());
        try {
            return firmware::sim::Trajectory::load(o.trajectory);
        } catch (const std::runtime_error& e) {
            throw InputError(std::string("--trajectory: ") + e.what());  // names the file and line
        }
    }();
    detail::check_session_length(camera, o.trajectory + ": ");  // before the map's load

    // The map after the trajectory: a bad file is told before a long load.
    LoadedExr loaded = load_exr(o.env);
    if (o.on_environment) o.on_environment(loaded);
    const HdrImage env = std::move(loaded.image);

    // One segment: the whole trajectory at o.fps.
    detail::SessionPlan plan;
    plan.camera = &camera;
    detail::SessionSegment scan;
    scan.fps = o.fps;
    scan.frames = scan_frames(camera, o.fps);
    scan.hdr_bracket = o.hdr_bracket;
    plan.segments.push_back(scan);
    return detail::write_planned_session(o, env, plan, progress);
}

int simulate_charuco_session(const SimulateOptions& o, int views) {
    if (views < 4 || views > 200) throw InputError("--charuco must be 4..200 views");
    if (o.width < 64 || o.height < 64) throw InputError("--size must be at least 64x64 for a ChArUco board");
    check_replaceable(o.out, o.overwrite);
    CameraCalibration truth;
    truth.intrinsics = Intrinsics::from_fov(o.width, o.height, o.horizontal_fov_deg * kDeg);
    truth.intrinsics.k1 = -0.08;
    truth.intrinsics.k2 = 0.012;
    CameraCalibration guess;
    guess.intrinsics = Intrinsics::from_fov(o.width, o.height, o.horizontal_fov_deg * kDeg);
    const capture::CharucoSpec spec;
    const double w = spec.squares_x * spec.square_m, h = spec.squares_y * spec.square_m;
    const fs::path partial = o.out.string() + ".partial";
    fs::remove_all(partial);
    fs::create_directories(partial / "frames");
    fs::create_directories(partial / "truth");
    try {
        std::string frames_csv = capture::frames_csv_header() + "\n";
        for (int k = 0; k < views; ++k) {
            // Poses spread over tilts, in-plane turns, distances and image positions (deterministic).
            const double a = 25 * std::sin(1.7 * k) * kDeg, b = 25 * std::cos(1.3 * k) * kDeg, c = 10 * std::sin(0.9 * k) * kDeg;
            const cv::Matx33d Rx(1, 0, 0, 0, std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a));
            const cv::Matx33d Ry(std::cos(b), 0, std::sin(b), 0, 1, 0, -std::sin(b), 0, std::cos(b));
            const cv::Matx33d Rz(std::cos(c), -std::sin(c), 0, std::sin(c), std::cos(c), 0, 0, 0, 1);
            const cv::Matx33d R = Rx * Ry * Rz;
            const double dist = 0.3 + 0.3 * (0.5 + 0.5 * std::sin(2.3 * k));
            // Off-centre too: the corners of the image must see corners of the board, or the
            // distortion there is a guess.
            const cv::Vec3d centre(0.3 * std::sin(3.1 * k) * dist, 0.17 * std::cos(2.7 * k) * dist, dist);
            const cv::Vec3d origin = centre - R * cv::Vec3d(w / 2, h / 2, 0);
            const cv::Mat rgb = capture::render_charuco_view(spec, truth.intrinsics, R, origin);
            char name[32];
            std::snprintf(name, sizeof name, "frames/%06d.png", k);
            if (!cv::imwrite((partial / name).string(), rgb)) throw RuntimeError((partial / name).string() + ": cannot write");
            const capture::FrameRecord record{std::uint64_t(k), std::int64_t(k + 1) * 1'000'000'000, 0.01, 1, 1, name};
            frames_csv += capture::frames_csv_line(record) + "\n";
        }
        write_text(partial / "frames.csv", frames_csv);
        capture::save_calibration(partial / "calibration.json", guess);
        capture::save_calibration(partial / "truth" / "calibration.json", truth);
        write_text(partial / "session.json", capture::session_json("glint simulate --charuco"));
        if (fs::exists(o.out)) fs::remove_all(o.out);
        fs::rename(partial, o.out);
    } catch (...) {
        std::error_code ignored;
        fs::remove_all(partial, ignored);
        throw;
    }
    return views;
}

void add_simulator_camera(capture::CameraBackends& backends) {
    backends["simulator"] = {
        "simulator:ENV.exr", [](const std::string& spec, const std::string& env, host::Clock& clock) {
            if (env.empty()) throw InputError("camera '" + spec + "': no environment map (simulator:ENV.exr)");
            const SimulateOptions o;
            const auto scan =
                std::make_shared<const firmware::sim::Trajectory>(guided_camera_trajectory(o.guided_speed_deg_s));
            CameraRun run;
            run.world_from_camera = [scan](double t_s) {
                return world_from_camera_at(*scan, std::uint64_t(std::llround(t_s * 1e6)));
            };
            run.fps = o.fps;
            run.frames = scan_frames(*scan, o.fps);
            run.threads = hardware_threads();
            const SensorModel sensor;
            return std::unique_ptr<capture::CameraSource>(std::make_unique<CameraSimulator>(
                load_exr(env).image, true_camera(o, sensor), std::move(run), clock, sensor, AutoExposureModel{},
                o.seed));
        }};
}

}  // namespace glint::sim
