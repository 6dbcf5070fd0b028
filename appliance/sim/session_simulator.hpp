// `glint simulate`: renders a recorded session with ground truth from any equirect HDR map. The
// camera follows a trajectory (the built-in guided scan or a file); the orientation stream comes
// from the sensor-board firmware's host build (firmware_bridge/firmware/sim) riding on the
// camera, with its own noise, bias drift and fusion, recorded byte for byte as the serial driver
// would record a live board (firmware_bridge/recording). See docs/capture.md "Simulated sessions".
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "appliance/capture/camera_factory.hpp"
#include "appliance/capture/camera_model.hpp"
#include "appliance/capture/exposure_controller.hpp"
#include "appliance/core/exr_io.hpp"
#include "firmware_bridge/firmware/sim/trajectory.hpp"

namespace glint::sim {

struct SimulateOptions {
    std::filesystem::path env;       // equirect HDR map (EXR)
    std::string trajectory = "guided";  // "guided", "alignment" or a file: t_seconds,w,x,y,z (world_from_camera)
    std::filesystem::path out;       // session directory (must not exist unless overwrite)
    bool overwrite = false;
    // Told of the map as loaded, before anything is rendered (the command warns of sanitised
    // values and a map that is not 2:1).
    std::function<void(const LoadedExr&)> on_environment;
    double fps = 4;                  // frames per second of camera time
    int width = 320, height = 180;   // frame size, pixels
    double horizontal_fov_deg = 70;
    std::string imu = "raw";         // "raw" (MPU-6050 + QMC5883L, Mahony on the board) or "bno055"
    std::string sensor_noise = "default";  // "none", "default", "high" (firmware simulator presets)
    bool camera_noise = true;
    // The camera sensor's noise (SensorModel): photo-electrons at relative exposure 1 and gain 1,
    // and the read noise's standard deviation in relative exposure. A smaller full well also makes
    // the same light brighter (relative exposure is electrons over the full well).
    double camera_full_well_electrons = 6000;
    double camera_read_noise = 0.002;
    double mount_yaw_deg = 2.0, mount_pitch_deg = -1.5, mount_roll_deg = 0.5;  // sensor_from_camera
    double clock_drift_ppm = 40;     // board clock rate against the appliance clock
    // The camera-sensor time offset (CameraCalibration::time_offset_s: camera timestamp + offset =
    // sensor time of the same instant): each frame is stamped this much before the sensor's time
    // of the instant it shows. Written to calibration.json and truth/calibration.json.
    double time_offset_s = 0;
    // A heading drift of the sensor's reported orientation, deg/min about world +Y, on top of its
    // own errors (a gyro bias the fusion does not see): the board is fed a world that turns.
    double heading_drift_deg_per_min = 0;
    double guided_speed_deg_s = 45;  // yaw speed of the built-in scan
    // Record what the capture pipeline's exposure controller (capture/exposure_controller.hpp, its
    // default settings) asks for: after a frame with any clipped pixel, frames 2 ms apart at 1/64,
    // 1/4096, ... of its exposure x gain until none clips (at most four, none shorter than the
    // sensor's shortest exposure), a top-up frame where the last reads a compact source low
    // (top_up_below below), then back to auto-exposure.
    bool hdr_bracket = false;
    // With hdr_bracket: frames an exposure request takes to apply, as on a real camera (libcamera:
    // 2-3). 0: from the next frame (the burst). The frames in between are recorded too.
    int control_delay_frames = 0;
    // With hdr_bracket: the controller's ExposureControlSettings::top_up_below (its default 1/8;
    // 0 = no top-up frames). For measuring them (docs/capture.md "Exposure control").
    double top_up_below = capture::ExposureControlSettings{}.top_up_below;
    // The modelled sensor's limits (camera_model.hpp kModelled*): a shortest exposure of 20 us,
    // where the brackets stop, and lens glare. Off: no shortest exposure, no glare.
    bool sensor_limits = false;
    // Motion: each pixel integrated over its exposure along the trajectory (`--no-motion-blur`
    // turns it off), and a rolling shutter reading the rows out top to bottom in readout_s
    // (`--readout-ms`; 0: a global shutter), written to calibration.json as "readout_s".
    bool motion_blur = true;
    double readout_s = capture::kModelledReadoutS;
    std::uint64_t seed = 1;
    int threads = 0;
    // How frames are stored: "png" (lossless) or "jpg" at jpeg_quality (cv::imwrite's 1..100).
    // `glint simulate` writes PNG; kiosk sessions JPEG (kiosk_simulator.hpp: measured there).
    std::string frame_format = "png";
    int jpeg_quality = 95;
    // A calibration session instead of a scan: `bracket` frames of one still view (the
    // trajectory's first orientation; the horizon for "guided"), auto-exposure off, exposure doubling from
    // `bracket_first_exposure_s` (glint calibrate response). 0 = a normal session.
    int bracket = 0;
    double bracket_first_exposure_s = 1e-4;
};

struct SimulateSummary {
    int frames = 0;
    double duration_s = 0;
    std::uint64_t sensor_bytes = 0;
    std::uint64_t orientation_messages = 0;
};

// The built-in guided scan (world_from_camera over camera time from 0): yaw sweeps of 360
// degrees at elevations -60, -30, 0, 30 and 60 degrees at 45 deg/s, 1.5 s pitch moves between
// them, and a last sweep looking up at 85 degrees; about 52 s.
std::vector<firmware::sim::TrajectorySample> guided_camera_trajectory(double speed_deg_s = 45);

// The built-in alignment motion (`--trajectory alignment`, for glint calibrate alignment): from
// the horizon, sinusoidal sweeps of +-`amplitude_deg` about yaw, then pitch, then roll (`cycles`
// periods of `period_s` each; 25 degrees over 3 s peaks at 52 deg/s), with 0.5 s still at both
// ends; about 19 s. Turning about all three axes makes every axis of the mounting observable,
// and the ever-changing speed the time offset. A technician can follow it with on-screen prompts.
std::vector<firmware::sim::TrajectorySample> alignment_camera_trajectory(double amplitude_deg = 25, double period_s = 3,
                                                                         int cycles = 2);

// world_from_camera = yaw about world +Y, then pitch about the camera's X, then roll about -Z.
glm::dquat camera_look(double yaw_deg, double pitch_deg, double roll_deg = 0);

// Adds the kind "simulator:ENV.exr" to a camera factory's table (capture/camera_factory.hpp):
// the true camera of a default `glint simulate` (SimulateOptions: its size, field of view, lens,
// noise and auto-exposure) rendering ENV.exr along the built-in guided scan at its frame rate.
void add_simulator_camera(capture::CameraBackends& backends);

// An intrinsics-calibration session: `views` frames of a ChArUco board (charuco.hpp) at varied
// poses, 0.3-0.6 m away, through the true camera of `options` (size, field of view, the
// simulator's lens distortion). calibration.json holds a distortion-free first guess from the
// field of view (what a camera has before calibration); truth/calibration.json the true one.
// No sensor stream. Same atomicity as simulate_session.
int simulate_charuco_session(const SimulateOptions& options, int views);

// Writes the session (into OUT.partial, renamed to OUT at the end: never a half session).
// progress(done, total) is called per frame. Throws InputError for bad options or inputs.
SimulateSummary simulate_session(const SimulateOptions& options,
                                 const std::function<void(long long, long long)>& progress = {});

}  // namespace glint::sim
