// A recorded capture session on disk (docs/capture.md "Session directory"): camera frames with
// their metadata, the stored camera calibration, the orientation sensor's recorded stream, and,
// for simulated sessions, the ground truth. `glint simulate` writes one; `glint capture` reads one.
//
//   SESSION/session.json     {"format": "glint-session", "version": 1, ...}
//   SESSION/calibration.json the camera calibration the appliance has on file (calibration_io.hpp)
//   SESSION/frames.csv       index,t_ns,exposure_s,analogue_gain,digital_gain,file
//   SESSION/frames/*         8-bit RGB frames: PNG (lossless), or JPEG (kiosk sessions, recordings)
//   SESSION/sensors.glrec    the sensor's recording (firmware_bridge/recording/FORMAT.md): a serial
//                            board's byte stream, or an I2C / Modbus source's published samples
//   SESSION/truth/           simulated sessions only: env.exr, camera.csv (index,t_ns,w,x,y,z:
//                            true world_from_camera per frame), calibration.json (the true one)
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "appliance/capture/camera_frame.hpp"
#include "appliance/capture/camera_model.hpp"

namespace glint::capture {

inline constexpr int kSessionVersion = 1;

// What frames.csv may say of a frame: exposures from 1 fs to 100 s, gains from 1/16 to 4096 (an
// analogue gain of 16 and a digital one of 256 at most on the sensors libcamera drives). Outside
// them the file is damaged. The lower bound is far below any real sensor's (tens of us) because
// the simulator without --sensor-limits brackets down to 1/64^4 of its exposure: from its
// shortest auto-exposure, 1e-4 s, that is 6e-12 s.
inline constexpr double kMinFrameExposureS = 1e-15;
inline constexpr double kMaxFrameExposureS = 100;
inline constexpr double kMinFrameGain = 1.0 / 16;
inline constexpr double kMaxFrameGain = 4096;

struct FrameRecord {
    std::uint64_t index = 0;
    std::int64_t t_ns = 0;  // appliance CLOCK_MONOTONIC at mid-exposure
    double exposure_s = 0;
    double analogue_gain = 1;
    double digital_gain = 1;
    std::string file;       // relative to the session directory
};

struct TruthPose {
    std::uint64_t index = 0;
    std::int64_t t_ns = 0;
    glm::dquat world_from_camera{1, 0, 0, 0};
};

struct Session {
    std::filesystem::path dir;
    CameraCalibration calibration;
    std::vector<FrameRecord> frames;
    std::filesystem::path sensors;  // the sensor recording (may be absent: empty path)
    bool has_truth = false;
};

// Reads session.json, calibration.json and frames.csv. Throws InputError naming the file (and
// line or key) for anything missing or malformed; frames must have increasing times and indices,
// and exposures and gains a camera can have.
Session open_session(const std::filesystem::path& dir);
// Loads one frame's image (PNG or JPEG); throws InputError naming the file.
CameraFrame load_frame(const Session& session, const FrameRecord& record);
// Throws InputError naming the frame's file and calibration.json unless `frame` is the size of the
// session's calibration: for readers that index frames by it (a smaller frame read past its end).
// Not in load_frame: an intrinsics or response calibration of a new camera mode reads frames of
// another size than the calibration in force.
void check_frame_size(const Session& session, const FrameRecord& record, const CameraFrame& frame);
// truth/camera.csv and truth/env.exr of a simulated session.
std::vector<TruthPose> load_truth_poses(const Session& session);
std::filesystem::path truth_env_path(const Session& session);

// Writing (for the simulator and for recording live sessions).
std::string frames_csv_header();
std::string frames_csv_line(const FrameRecord& r);
// truth/camera.csv (and `glint capture --orientations-out`): index,t_ns,w,x,y,z.
std::string camera_poses_csv_header();
std::string camera_poses_csv_line(const TruthPose& p);
std::string session_json(const std::string& created_by);

}  // namespace glint::capture
