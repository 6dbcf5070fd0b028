// Global adjustment of every frame's orientation after the scan (docs/capture.md "Global
// adjustment"): a pose graph over the frames, solved by Gauss-Newton.
//
// What each source knows:
//   - the images fix the rotation between two overlapping frames to a few hundredths of a
//     degree where there is texture (align_pair: direct photometric alignment of one frame's grid
//     against the other frame's log luminance, with the information matrix of the fit), but
//     nothing absolute;
//   - the sensor's short-term relative rotation is good (gyro integration over a fraction of a
//     second: a bracket frame 2 ms after its parent has its parent's error);
//   - the sensor's absolute orientation is right only on average: fusion noise of a few tenths of
//     a degree, and a drift that grows linearly (a gyro bias residual), zero at the start of the
//     capture by definition of the appliance's world frame.
// Unknowns: each frame's world_from_camera and the drift rate b. Cost:
//   sum over pairs  e_ij^T L_ij e_ij,     e_ij = log(R_i R_j^-1 M_ij^-1)   (M_ij measured)
// + sum over close frames |log(R_i R_j^-1 (S_i S_j^-1)^-1)|^2 / sigma_rel(dt)^2
// + sum over frames |log(R_f S_f^-1) - b t_f|^2 / sigma_sensor^2
// Frame-to-mosaic alignment (drift_correction.hpp) cannot do this: the mosaic inherits the drift
// of the frames that painted it, a warp the mosaic is consistent with.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "appliance/capture/camera_frame.hpp"
#include "appliance/capture/camera_model.hpp"

namespace glint::capture {

// A frame prepared for pairwise alignment: its log-luminance cells (s x s pixels each; NaN
// where clipped or too dark to trust) and a grid of samples with their camera rays.
struct AlignmentView {
    Intrinsics intrinsics;
    int s = 2, cells_w = 0, cells_h = 0;
    std::vector<float> log_lum;  // cells_w x cells_h
    std::vector<glm::dvec3> rays;
    std::vector<float> values;  // log luminance at each ray
};

// Measured (docs/capture.md "Global adjustment"): cells of 2x2 pixels and a 64-point grid gave
// better whole-scan results than full resolution with a 160-point grid, though the latter aligns
// a single textured pair closer.
AlignmentView make_alignment_view(const CameraFrame& frame, const CameraCalibration& calibration, int grid_width = 64,
                                  int s = 2);

struct PairMeasurement {
    int i = 0, j = 0;                      // frame indices (i is the one aligned)
    glm::dquat relative{1, 0, 0, 0};       // measured R_i R_j^-1 (world frame)
    glm::dmat3 information{0};             // of the error log(R_i R_j^-1 M^-1), rad^-2 (symmetric)
    double sigma_deg = 0;
    int points = 0;
};

struct PairSettings {
    int min_points = 150;
    double max_sigma_deg = 0.05;  // a fit less certain than this is no measurement
    double max_angle_deg = 3;     // a fit that moved further than this is a false minimum
    double min_sigma_deg = 0.01;  // floor: neighbouring grid samples are not independent
};

// Aligns frame a (orientation ra) to frame b (orientation rb); nullopt when they do not overlap
// enough or the fit is not trusted.
std::optional<PairMeasurement> align_pair(const AlignmentView& a, const glm::dquat& ra, const AlignmentView& b,
                                          const glm::dquat& rb, const PairSettings& settings = {});

struct AdjustmentSettings {
    double sensor_sigma_deg = 0.3;            // the fusion's absolute noise
    double relative_sigma_deg = 0.02;         // the sensor's relative rotation over dt -> 0 ...
    double relative_sigma_deg_per_s = 0.3;    // ... growing with dt
    double relative_max_dt_s = 0.5;           // frames closer than this get the sensor's relative constraint
    int iterations = 4;
};

struct AdjustmentResult {
    std::vector<glm::dquat> orientations;
    glm::dvec3 drift_rate_rad_per_s{0};
    int pairs_used = 0;
    double pair_rms_deg = 0;    // RMS of the pair errors after the solve
    double sensor_rms_deg = 0;  // RMS of log(R_f S_f^-1) - b t_f after the solve
};

// t_s: seconds from the first frame; sensor: world_from_camera from the sensor; initial: the
// starting point (e.g. the live pass's orientations).
AdjustmentResult adjust_orientations(const std::vector<double>& t_s, const std::vector<glm::dquat>& sensor,
                                     const std::vector<glm::dquat>& initial, const std::vector<PairMeasurement>& pairs,
                                     const AdjustmentSettings& settings = {});

// A whole scan: candidate pairs (for each frame that has enough valid samples, the two frames
// before it within half the field of view, and up to four frames more than 3 s earlier, another
// row or the sweep's start, nearest in direction), then `rounds` of aligning every candidate
// from the current orientations and solving. A pair's alignment keeps part of its starting error
// along the directions the images pin down weakly, so each round starts from the last solution
// (measured: sunset's error after 60 s 0.70 -> 0.52 -> 0.47 degrees over the first three).
struct ScanAdjustment {
    AdjustmentResult result;  // of the last round
    int pairs_tried = 0;      // candidate pairs
    std::string profile;      // wall times: pair selection, then alignment and solve per round
};

ScanAdjustment adjust_scan(const std::vector<AlignmentView>& views, const std::vector<double>& t_s,
                           const std::vector<glm::dquat>& sensor, std::vector<glm::dquat> initial, int rounds,
                           int threads,
                           const std::function<void()>& round_done = {}, const PairSettings& pair_settings = {},
                           const AdjustmentSettings& settings = {});

}  // namespace glint::capture
