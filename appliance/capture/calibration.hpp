// Camera calibrations computed from recorded frames (docs/capture.md "Calibration"). Each works
// on a session and returns what it estimated plus how well it fits; `glint calibrate ...`
// stores the result in the camera's calibration file (calibration_io.hpp).
#pragma once

#include "appliance/capture/camera_model.hpp"
#include "appliance/capture/session.hpp"

namespace glint::capture {

struct ResponseResult {
    Response response;   // the inverse response table, scaled so that code 254 is exposure 1
    int frames = 0;
    double exposure_span = 0;  // longest / shortest exposure of the bracket
};

// The inverse response curve from an exposure bracket of a still view (OpenCV's
// CalibrateRobertson, the three channels averaged: the table is shared by the channels).
// Throws InputError when the session is no usable bracket (fewer than 3 frames, exposures not
// spread over at least 8x).
ResponseResult calibrate_response(const Session& bracket);

}  // namespace glint::capture
