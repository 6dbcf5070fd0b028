// Camera calibrations computed from recorded frames (docs/capture.md "Calibration"). Each works
// on a session and returns what it estimated plus how well it fits; `glint calibrate ...`
// stores the result in the camera's calibration file (calibration_io.hpp).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "appliance/capture/camera_model.hpp"
#include "appliance/capture/capture_pipeline.hpp"
#include "appliance/capture/session.hpp"

namespace glint::capture {

struct ResponseResult {
    Response response;   // the inverse response table, scaled so that code 254 is exposure 1
    int frames = 0;
    double exposure_span = 0;  // longest / shortest exposure of the bracket
    // The codes whose exposure the bracket measured; outside them the table is extrapolated
    // (measured_high < measured_low: none, the table is Robertson's alone).
    int measured_low = 0, measured_high = -1;
};

// The inverse response curve from an exposure bracket of a still view: OpenCV's
// CalibrateRobertson (the three channels averaged: the table is shared by the channels), then
// refined against the sensor's noise, which biases Robertson's low codes: each pixel channel's
// radiance from its well-exposed reads, and the curve from the median code read at each known
// exposure (docs/capture.md, "Calibration"). Throws InputError when the session is no usable
// bracket (fewer than 3 frames, exposures not spread over at least 8x).
ResponseResult calibrate_response(const Session& bracket);

// What a response result measured, for the technician: "codes A..B measured", and where the
// curve is extrapolated over codes the capture weighs (32..250), what the bracket lacked.
std::string response_coverage(const ResponseResult& r);

struct VignettingResult {
    Vignetting vignetting;
    int frames = 0;
    long long pixels = 0;     // pixels used (not clipped, not dark, in every frame)
    double fit_rms = 0;       // RMS of the fitted polynomial against the measured falloff
};

// Vignetting from flat-field frames (a uniformly lit, featureless view filling the frame, e.g. a
// diffuser): every frame is linearised with the calibration's inverse response, the frames are
// averaged, normalised at the principal point, and V(r) = 1 + a1 r^2 + a2 r^4 + a3 r^6 is fitted
// by least squares. Throws InputError when too few usable pixels remain.
VignettingResult calibrate_vignetting(const Session& flat_field, const CameraCalibration& calibration);

struct NoiseResult {
    double full_well_electrons = 0;  // photo-electrons at relative exposure 1 and gain 1
    double read_noise = 0;           // standard deviation in relative exposure
    int pairs = 0;                   // consecutive frames compared
    long long samples = 0;           // pixel channels used
    int bins = 0;                    // exposure bins fitted
    double fit_rms = 0;              // RMS relative residual of the bins' variances
};

// The sensor's noise model (CameraCalibration::noise_*) from an exposure bracket of a still
// view (glint simulate --bracket N): consecutive frames see the same light, so in relative
// exposure X (the calibration's inverse response) the later frame reads rho times the earlier,
// rho = the ratio of their exposure x gain. The difference d = X' - rho X of a pixel channel read
// in both (codes 2..249) then has variance
//   (1/full_well) (rho X g' + rho^2 X g) + read^2 (1 + rho^2) + quantisation,
// the quantisation being each code's bin width squared over 12. The variance is taken per
// exposure bin about the bin's own mean difference (a response slightly off shifts the mean,
// not the spread), and full_well and read are fitted by weighted least squares over the bins.
// Throws InputError when the session holds fewer than two frames a factor 1.2-8 apart, too few
// pixels are read in both frames of a pair, or the bins' variances do not follow the model (no
// shot noise, or a fit RMS over 50 %: a noiseless recording, a moving view, a response far off).
NoiseResult calibrate_noise(const Session& bracket, const CameraCalibration& calibration);

// An alignment is not put in force when the motion leaves the mounting's standard deviation about
// some axis above this (degrees), as large as the mounting's target. The standard deviation is
// the noise's alone, with the time offset marginalised: the benchmark's errors are 2-5x it (a bias of the image
// rotations), so passing says the motion was usable, not that the mounting is within 0.3 degrees.
inline constexpr double kMaxMountingSdDeg = 0.3;

struct AlignmentResult {
    glm::dquat sensor_from_camera{1, 0, 0, 0};  // the mounting
    double time_offset_s = 0;     // camera time + offset = sensor time of the same instant
    int pairs = 0;                // frame pairs whose image rotation was measured
    double residual_deg = 0;      // median angle between image and (aligned) sensor relative rotations
    // The mounting's standard deviation about the axis the motion pinned down least, from the
    // pairs' turns and residuals (degrees), and that axis in the camera's frame.
    double mounting_sd_deg = 0;
    glm::dvec3 weakest_axis{0, 0, 1};
};

// The camera-sensor alignment from a capture with rotation-only motion (a scan): the relative
// rotation between consecutive frames is measured in the images (ORB features, RANSAC homography
// of the undistorted points, R = K^-1 H K orthonormalised) and compared with the sensor's relative
// rotation over the same interval; the mounting is the rotation that best maps the sensor's
// rotation axes onto the camera's (weighted by angle, Kabsch), and the time offset the one, on a
// 1 ms grid within +-`max_offset_s`, with the smallest residual. Needs the session's sensor
// stream. Throws InputError when fewer than 10 pairs could be measured. A single-axis scan gives
// the offset but leaves the mounting about the scan axis loose: see mounting_sd_deg.
AlignmentResult calibrate_alignment(const Session& capture, double max_offset_s = 0.05);
// The same from orientations at hand (the maintenance menu's wizard keeps them as they arrive:
// its sessions have no sensors.glrec). Time order; `capture`'s sensor recording is not read.
AlignmentResult calibrate_alignment(const Session& capture, const std::vector<SensorOrientation>& orientations,
                                    double max_offset_s = 0.05);

// The rolling shutter's readout time (calibration readout_s) from a motion with its sensor
// recording: the alignment (above) solved with the rows read out over each readout on a grid of
// kReadoutGridS steps from 0 (in spans of 50 ms, a span more while the best is the last searched,
// up to max_readout_s), and the readout whose pairs fit the sensor best (the mean square residual
// of the best 80 % of the pairs), refined by a parabola through its neighbours. A wrong readout
// shears and scales each frame's rays against the sensor's turn (docs/capture.md, "Readout").
// Throws InputError when the motion does not show it (a standard deviation from the parabola's
// curvature over kMaxReadoutSdS), or the best readout is the longest searched.
inline constexpr double kReadoutGridS = 0.0025;
inline constexpr double kMaxReadoutSdS = 0.003;
struct ReadoutResult {
    double readout_s = 0;
    double sd_s = 0;            // its standard deviation, from the fit's curvature and residuals
    int pairs = 0;              // pairs in the fit (the best 80 %)
    AlignmentResult alignment;  // mounting and time offset at that readout
};
ReadoutResult calibrate_readout(const Session& capture, double max_readout_s = 0.2, double max_offset_s = 0.05);
ReadoutResult calibrate_readout(const Session& capture, const std::vector<SensorOrientation>& orientations,
                                double max_readout_s = 0.2, double max_offset_s = 0.05);

// The alignment and, where the motion shows it, the readout, from one measurement of the frame
// pairs (the wizard's alignment run): the alignment at the measured readout, or at the
// calibration's with the reason the readout was not measured.
struct AlignmentAndReadout {
    AlignmentResult alignment;
    std::optional<ReadoutResult> readout;
    std::string readout_refused;  // why not, when readout is empty
};
AlignmentAndReadout calibrate_alignment_and_readout(const Session& capture,
                                                    const std::vector<SensorOrientation>& orientations,
                                                    double max_readout_s = 0.2, double max_offset_s = 0.05);

// Throws InputError, `where` first, naming the axis and how loose the mounting is there, when the
// motion did not pin it down to kMaxMountingSdDeg: `glint calibrate alignment` and the wizard
// then write nothing and keep the calibration in force.
void check_alignment_usable(const AlignmentResult& result, const std::string& where);

}  // namespace glint::capture
