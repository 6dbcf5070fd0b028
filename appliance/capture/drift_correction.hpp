// Drift correction: before a frame is accumulated, the small rotation that best aligns it with
// what is already on the sphere is estimated and applied on top of the sensor's orientation.
//
// Method (direct photometric alignment, docs/capture.md "Drift correction"): the frame is
// linearised and box filtered to a coarse grid (about `grid_width` pixels across) of radiance
// estimates; each grid pixel's ray is turned into the world by exp(delta) * world_from_camera and
// the sphere's radiance is read there. delta (a world-frame rotation vector) minimises the sum of
// squared differences of log luminance (exposure-independent, so auto-exposure does not bias it)
// over pixels whose sphere texel is covered, by Gauss-Newton with numerical derivatives, starting
// from no correction. The correction applied to frames is a low-pass of the trusted estimates
// (DriftSettings::gain); an estimate is trusted when enough pixels overlap, the residual falls,
// it is under `max_correction_deg`, and its standard deviation under `max_sigma_deg`.
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
    // Fusion with the sensor: the correction carried to the frames is a low-pass of the measured
    // offsets, c <- c + gain (offset - c) per trusted frame. A sensor drift that grows slowly is
    // followed in full; the noise of single frame-to-mosaic alignments is averaged, not applied
    // frame by frame (which chains them into a random walk).
    double gain = 0.1;
    // On top of that slow part, the share of the frame's own measured offset beyond it applied to
    // that frame alone: the sensor's faster wander (fusion noise) is not a drift.
    double frame_share = 0.6;
};

struct DriftEstimate {
    glm::dquat correction{1, 0, 0, 0};     // world-frame: corrected = correction * world_from_camera
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

    // The frame's offset against the sphere, fused for a live capture: the slow part carried from
    // frame to frame plus a share of this frame's own offset (DriftSettings::gain, frame_share).
    // sphere: the radiance accumulated so far; samples: per texel, 0 = not covered.
    DriftEstimate estimate(const CameraFrame& frame, const CameraCalibration& calibration,
                           const glm::dquat& world_from_camera,
                           const HdrImage& sphere, const std::vector<std::uint32_t>& samples);
    // The slow correction carried from frame to frame (for frames without a trusted estimate).
    const glm::dquat& carried() const { return carried_; }

private:
    // The alignment alone: `correction` is the full measured offset (exp(delta)) and `applied`
    // says whether it is trusted; no fusion, no state.
    DriftEstimate measure(const CameraFrame& frame, const CameraCalibration& calibration,
                          const glm::dquat& world_from_camera,
                          const HdrImage& sphere, const std::vector<std::uint32_t>& samples) const;

    DriftSettings settings_;
    glm::dquat carried_{1, 0, 0, 0};
};

}  // namespace glint::capture
