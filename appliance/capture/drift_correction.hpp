// Drift correction: before a frame is accumulated, the small rotation that best aligns it with
// what is already on the sphere is estimated and applied on top of the sensor's orientation.
//
// Method (direct photometric alignment, docs/capture.md "Drift correction"): the frame is
// linearised and box filtered to a coarse grid (about `grid_width` pixels across) of radiance
// estimates; each grid pixel's ray is turned into the world by exp(delta) * world_from_camera and
// the sphere's radiance is read there. delta (a world-frame rotation vector) minimises the sum of
// squared differences of log luminance (exposure-independent, so auto-exposure does not bias it)
// over pixels whose sphere texel is covered, by Gauss-Newton with numerical derivatives, starting
// from the previous frame's correction (sensor drift changes slowly). A correction is applied
// when enough pixels overlap and the residual falls; it is limited to `max_correction_deg`.
#pragma once

#include <cstdint>
#include <vector>

#include "appliance/capture/camera_frame.hpp"
#include "appliance/capture/camera_model.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::capture {

struct DriftSettings {
    int grid_width = 64;            // grid pixels across the frame
    int min_pixels = 150;           // overlapping grid pixels needed to estimate anything
    double max_correction_deg = 3;  // |delta| limit: beyond it the estimate is not trusted
    // Uncertainty limit: the estimate's standard deviation (from the residuals and the normal
    // equations) must be below this, or the frame's texture does not pin the rotation down.
    double max_sigma_deg = 0.02;
    int iterations = 8;
    bool carry = false;             // start from the previous frame's correction (else from none)
    // Fusion with the sensor: the share of the image's estimate applied (1 = trust the image
    // alone). Frame-to-mosaic alignments chain, so their small errors add up along a scan like a
    // random walk, while the sensor's error stays bounded: a share below 1 damps the walk.
    // 0.6 from the guided scan on courtyard, studio and sunset (docs/capture.md).
    double gain = 0.6;
};

struct DriftEstimate {
    Quatd correction = Quatd::identity();  // world-frame: corrected = correction * world_from_camera
    double angle_deg = 0;                  // |correction|
    double residual_before = 0;            // RMS of log-luminance differences with the prior
    double residual_after = 0;             // ... with the estimate
    int pixels = 0;                        // grid pixels that overlapped covered texels
    double sigma_deg = 0;                  // standard deviation of the estimate (per axis)
    bool applied = false;                  // false: too little overlap, or no improvement
};

class DriftCorrector {
public:
    explicit DriftCorrector(DriftSettings settings = {}) : settings_(settings) {}

    // sphere: the radiance accumulated so far; samples: per texel, 0 = not covered.
    DriftEstimate estimate(const CameraFrame& frame, const CameraCalibration& calibration, const Quatd& world_from_camera,
                           const HdrImage& sphere, const std::vector<std::uint32_t>& samples);
    // The correction carried from frame to frame (the last applied one).
    const Quatd& carried() const { return carried_; }

private:
    DriftSettings settings_;
    Quatd carried_ = Quatd::identity();
};

}  // namespace glint::capture
