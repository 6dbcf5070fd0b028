// After the scan: the frames' orientations are re-estimated against the whole sphere and tied
// back to the sensor's frame of reference (docs/capture.md "Global refinement").
//
// The images fix the frames' orientations relative to each other to a few hundredths of a
// degree, but not the sphere's orientation as a whole: frame-to-mosaic alignment inherits
// whatever the first frames' sensor error was, and a live low-pass lags a drift that keeps
// growing. The sensor fixes the absolute frame, but drifts. So, with the offset of each
// image-aligned frame against its sensor orientation r_f = log(image_f sensor_f^-1) (a world-frame
// rotation vector), a robust line r(t) = a + b t is fitted over the trusted frames:
//   - b is the sensor's drift rate (gyro bias residual: heading error grows linearly);
//   - a is the sphere's own offset from the sensor at the start of the capture, where the drift
//     is zero by definition (the appliance's world frame is the sensor's at the start), averaged
//     over every trusted frame instead of taken from the first one.
// Trusted frames become exp(-a) image_f. A frame without a trusted alignment of its own (a dark
// bracket frame, featureless sky) takes the correction of the nearest trusted frame within
// `hold_s` (the sensor's error is the same 2 ms later), or else the drift line's.
#pragma once

#include <vector>

#include "appliance/capture/camera_model.hpp"

namespace glint::capture {

struct RefinedFrame {
    double t_s = 0;                   // seconds from the first frame
    Quatd sensor = Quatd::identity();  // world_from_camera from the sensor (and the mounting)
    Quatd image = Quatd::identity();   // world_from_camera aligned to the sphere (trusted frames)
    bool trusted = false;
};

struct DriftLine {
    firmware::Vec3d offset_rad{};     // a: the sphere's offset from the sensor at t = 0
    firmware::Vec3d rate_rad_per_s{};  // b: the sensor's drift rate
    int frames = 0;                   // trusted frames the fit used
    double residual_rms_deg = 0;      // RMS of the fit's residuals (the sensor's fusion noise)
};

struct AnchorSettings {
    int min_trusted = 8;      // fewer trusted frames: no fit, the orientations are returned as given
    double min_span_s = 5;    // the trusted frames must span this much time to fit a rate (else b = 0)
    double hold_s = 1.0;      // an untrusted frame takes a trusted neighbour's correction within this
};

// world_from_camera per frame (same order). `line` receives the fit (nullopt-like: frames = 0
// when there were too few trusted frames; the frames' image or sensor orientations are returned).
std::vector<Quatd> anchor_to_sensor(const std::vector<RefinedFrame>& frames, DriftLine* line = nullptr,
                                    AnchorSettings settings = {});

}  // namespace glint::capture
