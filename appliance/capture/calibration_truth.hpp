// Calibrations to update, and how far a calibration is from a simulated session's truth
// (SESSION/truth/calibration.json, written by glint simulate).
#pragma once

#include <filesystem>

#include "appliance/capture/camera_model.hpp"
#include "appliance/capture/session.hpp"

namespace glint::capture {

// The calibration a `glint calibrate` step starts from: `file` when it exists, else the
// session's own calibration.json (so a first step creates the file).
CameraCalibration calibration_to_update(const std::filesystem::path& file, const Session& session);

// The session's true calibration; InputError when the session has no truth.
CameraCalibration truth_calibration(const Session& session);

// Worst relative error of an inverse response against the truth over codes 64..250, both taken
// as ratios to code 128 (a response's scale is free). Below code 64 the simulator's read noise
// (0.002 of full scale, code 61) dominates what a code means; 251..255 are next to clipping.
double response_error_against_truth(const Response& estimate, const Response& truth);

// How far a noise model is from the truth's, as relative errors of the full well and the read
// noise, with the truth taken into the estimate's units of relative exposure: a calibrated
// response puts code 254 at 1, so X there = scale x X in the truth, scale the median ratio of
// the two inverse responses over codes 64..200 (full well / scale, read noise x scale).
struct NoiseError {
    double full_well = 0, read_noise = 0;
};
NoiseError noise_error_against_truth(double full_well_electrons, double read_noise, const Response& response,
                                     const CameraCalibration& truth);

// Angle between two mountings (sensor_from_camera), degrees.
double mounting_error_deg(const glm::dquat& estimate, const glm::dquat& truth);

}  // namespace glint::capture
