// Renders an equirect HDR environment through the camera model of camera_model.hpp: lens
// distortion, vignetting, exposure and gain, shot and read noise, the response curve and 8-bit
// quantisation, with an auto-exposure loop that lags behind the scene (so that overlapping
// frames differ in exposure, as a phone's or a Pi camera's do). Deterministic for a seed.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "appliance/capture/camera_frame.hpp"
#include "appliance/capture/camera_model.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::capture {

struct SensorModel {
    double electrons_per_radiance_second = 6.0e5;  // photo-electrons per unit radiance per second
    double full_well_electrons = 6000;             // electrons at relative exposure 1 (gain 1)
    double read_noise = 0.002;                     // relative exposure units, standard deviation
    bool noise = true;
};

struct AutoExposureModel {
    bool enabled = true;
    double target = 0.18;        // mean relative exposure the loop aims at
    double rate = 0.5;           // share of the (log) correction applied per frame: the lag
    double min_exposure_s = 1e-4;
    double max_exposure_s = 1.0 / 30.0;
    double max_gain = 8;
};

class CameraSimulator {
public:
    CameraSimulator(const HdrImage& environment, CameraCalibration truth, SensorModel sensor = {},
                    AutoExposureModel auto_exposure = {}, std::uint64_t seed = 1);

    // Renders the frame seen with world_from_camera at the current exposure and gain, then lets
    // the auto-exposure loop react to it (the next frame's settings). t_ns is copied into the frame.
    CameraFrame render(const glm::dquat& world_from_camera, std::int64_t t_ns, int threads = 1);

    // Relative exposure (before noise and response) of one pixel: what a perfect sensor records.
    double exposure_of(double radiance, double vignetting) const;

    void set_exposure(double exposure_s, double gain);
    double exposure_s() const { return exposure_s_; }
    double gain() const { return gain_; }
    const CameraCalibration& truth() const { return truth_; }

private:
    const HdrImage& env_;
    CameraCalibration truth_;
    SensorModel sensor_;
    AutoExposureModel ae_;
    std::uint64_t seed_;
    std::uint64_t frames_ = 0;
    double exposure_s_ = 1.0 / 120.0;
    double gain_ = 1;
    std::vector<glm::dvec3> rays_;  // camera-frame ray per pixel (row-major)
    std::vector<double> vignette_;  // V per pixel
};

}  // namespace glint::capture
