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
//   sum over pairs  e_ij^T L_ij e_ij,     e_ij = log(R_i C_ij^-1 R_j^-1)   (C_ij = R_j^-1 R_i measured)
// + sum over close frames |log(R_i (S'_j^-1 S'_i)^-1 R_j^-1)|^2 / sigma_rel(dt)^2
//   (S'_f = S_f exp(delta + w_f tau) with the refinement below, else S_f)
// + sum over frames |log(R_f exp(-delta - w_f tau) S_f^-1) - b t_f|^2 / sigma_sensor^2
// + |delta|^2 / sigma_mount^2 + tau^2 / sigma_tau^2
// (b about the world's vertical, heading, unless AdjustmentSettings says otherwise; delta and tau
// refine the camera-sensor calibration, AdjustmentSettings::refine_calibration)
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
    // Measured R_j^-1 R_i: camera j from camera i. The images know only this; a world-frame
    // R_i R_j^-1 would tie the pair to the absolute orientations it was measured at (for frames
    // 30 degrees apart, a common 0.5 degree rotation changes it by 0.25 degrees).
    glm::dquat relative{1, 0, 0, 0};
    glm::dmat3 information{0};             // of the error, expressed in camera j's frame, rad^-2 (symmetric)
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
    // Robust weight of a pair whose error is m of its own standard deviations (Mahalanobis):
    // Huber, 1 up to pair_robust_k and k / m beyond; with pair_cauchy, 1 / (1 + (m / k)^2).
    double pair_robust_k = 3;
    bool pair_cauchy = false;
    // Reweight from the first iteration (a warm start); otherwise the first takes every pair whole.
    bool robust_from_start = false;
    // The drift line b t_f about the world's vertical only (b = beta (0, 1, 0)): the board's
    // fusion holds tilt to gravity, so a tilt error is a transient or noise, not a drift, and
    // only heading drifts (a gyro bias about the vertical that no accelerometer sees). A free
    // three-axis rate turns the fusion's start-up transient (its first seconds a few tenths of a
    // degree off in tilt) into a tilt drift plus a constant tilt of the whole map: 0.13 degrees
    // on forest, both seeds (docs/capture.md, "Global adjustment"). false: a rate about any axis.
    bool drift_heading_only = true;
    // The camera-sensor calibration refined with the scan: a small rotation delta of the
    // mounting (camera frame) and a change tau of the time offset, so that the sensor's term
    // reads R_f = S_f exp(delta + w_f tau) (w_f the camera's angular velocity, camera frame;
    // tau only when the rates are given). A calibration.json gone stale (the camera knocked on its
    // mount, a new cable's latency) otherwise leaves a rotating error the drift line cannot take:
    // mounting about 3 degrees off gave 3.7 degrees after 60 s, a time offset 15 ms off 1.2 degrees
    // (courtyard, 2026-12-07). Gaussian priors about the calibration keep them in place where
    // the scan does not observe them (its first frames, a turn about one axis).
    // Off by default: where the scan turns mostly about the camera's own vertical, the mounting's
    // part about it trades against the map's heading, which the sensor alone fixes, and a free
    // refinement moved a right calibration's scan by 0.25 degrees (GlobalAdjustment tests). The
    // capture pipeline solves with it after the scan and keeps that solution only when it finds
    // the calibration stale (capture_pipeline.hpp, kStaleMountingDeg and kStaleTimeOffsetMs).
    bool refine_calibration = false;
    double mounting_prior_deg = 2;
    double time_offset_prior_ms = 20;
};

struct AdjustmentResult {
    std::vector<glm::dquat> orientations;
    glm::dvec3 drift_rate_rad_per_s{0};
    // The refinement of the calibration (AdjustmentSettings::refine_calibration): the mounting's
    // rotation vector delta (camera frame, rad; world_from_camera = sensor's x exp(delta)) and the
    // time offset's change (s, added to CameraCalibration::time_offset_s).
    glm::dvec3 mounting_rad{0};
    double time_offset_s = 0;
    // What the refinement does to the frames: the RMS over frames of |delta + w_f tau|, degrees.
    // At one speed of turn a time offset and the mounting's yaw trade against each other, and
    // this, not either alone, is what the scan measures.
    double calibration_turn_deg = 0;
    int pairs_used = 0;
    double pair_rms_deg = 0;    // RMS of the pair errors after the solve
    double sensor_rms_deg = 0;  // RMS of the sensor's absolute term (log(R_f S_f^-1) - b t_f, refined) after the solve
};

// t_s: seconds from the first frame; sensor: world_from_camera from the sensor; initial: the
// starting point (e.g. the live pass's orientations); camera_rates (optional, empty or one per
// frame): the camera's angular velocity at each frame, camera frame, rad/s, for the time offset's
// refinement.
AdjustmentResult adjust_orientations(const std::vector<double>& t_s, const std::vector<glm::dquat>& sensor,
                                     const std::vector<glm::dquat>& initial, const std::vector<PairMeasurement>& pairs,
                                     const AdjustmentSettings& settings = {},
                                     const std::vector<glm::dvec3>& camera_rates = {});

// Candidate pairs of a scan, from the frames' orientations: for each frame that has enough valid
// samples, the two frames before it within half the field of view, and up to four frames more
// than 3 s earlier (another row, or the sweep's start) nearest in direction. Causal: frame i's
// pairs depend only on frames 0..i.
std::vector<std::pair<int, int>> candidate_pairs_of_frame(const std::vector<AlignmentView>& views,
                                                          const std::vector<double>& t_s,
                                                          const std::vector<glm::dquat>& orientations, int i,
                                                          const PairSettings& pair_settings = {});

// A whole scan after the fact: the candidate pairs, then `rounds` of aligning every candidate
// from the current orientations and solving. A pair's alignment keeps part of its starting error
// along the directions the images pin down weakly, so each round starts from the last solution.
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

// The same adjustment while the scan runs (docs/capture.md "Global adjustment"): each frame's
// candidate pairs are aligned as it arrives, from the current solution; after each frame the
// pose graph is solved again (warm, sparse) and the pairs whose starting relative rotation the
// solution has moved most are aligned again, a few per frame. The rounds of adjust_scan become a
// standing rule: a pair is aligned again whenever its start has moved more than a threshold
// since it was last aligned. After the last frame only what moved since is left to do.
class OnlineAdjustment {
public:
    explicit OnlineAdjustment(int threads, const PairSettings& pair_settings = {},
                              const AdjustmentSettings& settings = {});

    // The next frame, in time order: its view, seconds from the first frame, the sensor's
    // world_from_camera and the live pass's. Its candidate pairs (chosen by the live
    // orientations) are aligned from the current solution, the frame itself started from its
    // live orientation carried by the last frame's correction.
    // camera_rate: the camera's angular velocity (camera frame, rad/s) for the time offset's
    // refinement (AdjustmentSettings::refine_calibration).
    void add_frame(AlignmentView view, double t_s, const glm::dquat& sensor, const glm::dquat& live,
                   const glm::dvec3& camera_rate = glm::dvec3(0));
    // Aligns again, most moved first, up to max_pairs (all when negative) candidate pairs whose
    // starting relative rotation moved more than min_change_deg since they were last aligned.
    // Returns how many it aligned.
    int realign(int max_pairs, double min_change_deg);
    // Solves the pose graph from the current solution.
    void solve();

    int frames() const { return int(q_.size()); }
    int pairs_tried() const { return int(pairs_.size()); }
    long long alignments() const { return alignments_; }  // align_pair calls so far
    const std::vector<glm::dquat>& orientations() const { return q_; }
    const AdjustmentResult& result() const { return result_; }
    // A solve from the current solution with the camera-sensor calibration refined
    // (AdjustmentSettings::refine_calibration), not kept: adopt() keeps it.
    AdjustmentResult refined_solution() const;
    void adopt(const AdjustmentResult& result);
    // From now on every solve refines the calibration (after a refined solution was adopted).
    void refine_calibration_from_now() { settings_.refine_calibration = true; }
    // The pairs measured (the ones the last alignment trusted).
    std::vector<PairMeasurement> measured_pairs() const;
    // The largest starting change of a pair since it was last aligned, degrees.
    double largest_pair_change_deg() const;

private:
    struct Pair {
        int i = 0, j = 0;
        glm::dquat start{1, 0, 0, 0};  // R_j^-1 R_i it was last aligned from
        std::optional<PairMeasurement> measured;
    };
    void align(const std::vector<std::size_t>& which);
    double change_deg(const Pair& p) const;

    int threads_;
    PairSettings pair_settings_;
    AdjustmentSettings settings_;
    std::vector<AlignmentView> views_;
    std::vector<double> t_s_;
    std::vector<glm::dquat> sensor_, live_, q_;
    std::vector<glm::dvec3> rates_;
    std::vector<Pair> pairs_;
    AdjustmentResult result_;
    long long alignments_ = 0;
};

}  // namespace glint::capture
