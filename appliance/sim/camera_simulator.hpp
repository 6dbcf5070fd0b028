// Renders an equirect HDR environment through the camera model of camera_model.hpp: lens
// distortion, vignetting, exposure and gain, shot and read noise, the response curve and 8-bit
// quantisation, with an auto-exposure loop that lags behind the scene (so that overlapping
// frames differ in exposure, as a phone's or a Pi camera's do). Deterministic for a seed.
//
// Motion: a frame is rendered along a camera path (world_from_camera as a function of time),
// each pixel integrated over its exposure along it (motion blur), its row exposed later than the
// row above it by the calibration's readout_s / height (a rolling shutter), so row v's exposure
// is centred readout_s x (v - (H - 1) / 2) / H after the frame's time: the frame's timestamp is
// the middle row's mid-exposure. A still view renders exactly as a single orientation.
//
// Two faces: the renderer (render(): any orientation or path at any time, what the session
// simulator needs for its brackets), and a capture::CameraSource that takes frames along a CameraRun, paced
// on a clock like a replay (camera_factory.hpp's "simulator:" kind, session_simulator.hpp).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <random>
#include <vector>

#include "appliance/capture/camera_frame.hpp"
#include "appliance/capture/camera_model.hpp"
#include "appliance/capture/camera_source.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::sim {

struct SensorModel {
    double electrons_per_radiance_second = 6.0e5;  // photo-electrons per unit radiance per second
    double full_well_electrons = 6000;             // electrons at relative exposure 1 (gain 1)
    double read_noise = 0.002;                     // relative exposure units, standard deviation
    bool noise = true;
    // Each pixel integrated over its exposure along the camera path (time samples about one
    // pixel of motion apart). Off: the whole exposure at the row's mid-exposure orientation.
    bool motion_blur = true;
};

// world_from_camera at `offset_s` seconds after the frame's time (the middle row's mid-exposure).
using CameraPath = std::function<glm::dquat(double offset_s)>;

// Geometry near the camera, in front of the environment (which lies at infinity): the kiosk's
// table with the board on it and a visitor's arm passing by (kiosk_simulator.hpp). A ray from
// `origin` (world frame, metres) along the unit `direction`, at time `t_s` of the scene's clock,
// that meets it gets the radiance returned; nullopt: it sees the map.
class LocalScene {
public:
    virtual ~LocalScene() = default;
    virtual std::optional<Rgb> radiance(double t_s, const glm::dvec3& origin, const glm::dvec3& direction) const = 0;
};

// Where the camera is, for a frame that sees a LocalScene: the camera's position (world frame,
// metres) at `offset_s` seconds after the frame's time, sampled at the same times as its
// orientation (the motion blur's time samples follow the turn only; a slow walk adds parallax
// of well under a pixel per exposure); the frame's time is t_s on the scene's clock.
struct LocalView {
    const LocalScene* scene = nullptr;
    std::function<glm::dvec3(double offset_s)> position;
    double t_s = 0;
};

struct AutoExposureModel {
    bool enabled = true;
    double target = 0.18;        // mean relative exposure the loop aims at
    double rate = 0.5;           // share of the (log) correction applied per frame: the lag
    double min_exposure_s = 1e-4;
    double max_exposure_s = 1.0 / 30.0;
    double max_gain = 8;
};

// What the simulator does as a CameraSource: `frames` frames at `fps`, the k-th due k / fps
// seconds after start() and looking along world_from_camera(k / fps) in its middle row's
// mid-exposure (each row and exposure along world_from_camera around it: motion blur and the
// truth's rolling shutter).
struct CameraRun {
    std::function<glm::dquat(double t_s)> world_from_camera;
    double fps = 4;
    int frames = 0;
    int threads = 1;  // render threads
};

class CameraSimulator final : public capture::CameraSource {
public:
    // The renderer alone: as a CameraSource it has no frames.
    CameraSimulator(HdrImage environment, capture::CameraCalibration truth, SensorModel sensor = {},
                    AutoExposureModel auto_exposure = {}, std::uint64_t seed = 1);
    // A camera taking the frames of `run`, each when `clock` reaches its due time (a VirtualClock:
    // as fast as they are read), stamped with that time.
    CameraSimulator(HdrImage environment, capture::CameraCalibration truth, CameraRun run, host::Clock& clock,
                    SensorModel sensor = {}, AutoExposureModel auto_exposure = {}, std::uint64_t seed = 1);

    // Renders the frame seen with world_from_camera at the current exposure and gain, then lets
    // the auto-exposure loop react to it (the next frame's settings). t_ns is copied into the frame.
    capture::CameraFrame render(const glm::dquat& world_from_camera, std::int64_t t_ns, int threads = 1);
    // The same along a moving camera: motion blur (SensorModel::motion_blur) and the rolling
    // shutter (the truth's readout_s) sample `path` over each row's exposure.
    capture::CameraFrame render(const CameraPath& path, std::int64_t t_ns, int threads = 1);
    // The same with a local scene in front of the map (`local.scene` may be null: the map alone).
    // The brightest texels' points (split_bright_texels) behind the scene are hidden by it.
    capture::CameraFrame render(const CameraPath& path, const LocalView& local, std::int64_t t_ns, int threads = 1);
    // Time samples per pixel of row v's exposure along `path` (1 when still or without motion
    // blur): what render() uses, for tests and timing.
    int time_samples(const CameraPath& path, int v) const;

    // Relative exposure (before noise and response) of one pixel: what a perfect sensor records.
    double exposure_of(double radiance, double vignetting) const;

    // Exposure and gain of the next rendered frame (the auto-exposure loop goes on from there).
    void set_exposure(double exposure_s, double gain);
    double exposure_s() const { return exposure_s_; }
    double gain() const { return gain_; }
    const capture::CameraCalibration& truth() const { return truth_; }

    // capture::CameraSource. start() begins the run again from the same state (frame count,
    // exposure), so a second run gives the same frames.
    std::string describe() const override;
    void start() override;
    void stop() override { running_ = false; }
    std::optional<capture::CameraFrame> next_frame(std::chrono::milliseconds timeout) override;
    // Manual requests take effect from the next frame and are where every later run starts.
    void set_exposure(const capture::ExposureRequest& request) override;
    bool finished() const override { return next_ >= run_.frames; }
    capture::CameraHealth health() const override { return health_; }

private:
    // The brightest texels' light above a level, as points (split_bright_texels()).
    struct Splat {
        glm::dvec3 direction;  // world frame
        Rgb energy;            // radiance x the point's solid angle
    };
    static constexpr int kSplatSide = 4;                   // points per texel side
    static constexpr double kSplatAboveMean = 4;           // the level, in map means
    static constexpr std::size_t kMaxSplatTexels = 65536;  // at most this many texels split
    void split_bright_texels();
    void splat_bright_texels(cv::Mat& light, const std::vector<std::vector<glm::dquat>>& row_views,
                             const LocalView& local, const std::vector<std::vector<glm::dvec3>>& row_positions,
                             const std::vector<std::vector<double>>& row_times) const;

    HdrImage env_;  // the map, less the split texels' excess
    capture::CameraCalibration truth_;
    SensorModel sensor_;
    AutoExposureModel ae_;
    std::uint64_t seed_;
    std::uint64_t frames_ = 0;
    double exposure_s_ = 1.0 / 120.0;
    double gain_ = 1;
    std::vector<glm::dvec3> rays_;  // camera-frame ray per pixel (row-major)
    std::vector<double> vignette_;  // V per pixel
    std::vector<double> pixel_omega_;  // solid angle per pixel, sr
    std::vector<Splat> splats_;
    double glare_px_min_ = 0, glare_px_max_ = 0;  // the glare's width in pixels, narrowest and widest
    std::vector<double> glare_mix_;                // per pixel: 0 narrowest .. 1 widest
    // The CameraSource face.
    CameraRun run_;
    host::Clock* clock_ = nullptr;  // set whenever run_ has frames
    double run_exposure_s_ = 0, run_gain_ = 1;  // where each run starts
    int next_ = 0;
    bool running_ = false;
    std::uint64_t start_us_ = 0;
    capture::CameraHealth health_;
};

}  // namespace glint::sim
