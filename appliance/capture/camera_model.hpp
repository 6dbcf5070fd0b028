// The camera as the capture pipeline models it: a pinhole with OpenCV's radial-tangential
// distortion, vignetting, a response curve, and its mounting on the orientation sensor.
//
// Frames of reference (see docs/capture.md):
// - Pixels follow OpenCV: (u, v) with u to the right and v down, pixel centres at integers,
//   (0, 0) the centre of the top-left pixel. Intrinsics and distortion are OpenCV's
//   (fx, fy, cx, cy; k1, k2, p1, p2, k3), so cv::calibrateCamera results drop in unchanged.
// - The camera frame follows the world frame's habit (docs/conventions.md, OpenGL): the camera
//   looks along -Z, +Y is up in the image, +X right. A camera-frame direction (X, Y, Z) with
//   Z < 0 has OpenCV normalised coordinates x = X / -Z, y = -Y / -Z.
// - world_from_camera rotates camera-frame vectors into the world frame; it is the sensor's
//   world_from_sensor times the calibrated sensor_from_camera alignment.
#pragma once

#include <array>
#include <optional>

#include "appliance/core/equirect.hpp"
#include "appliance/core/rotation.hpp"

namespace glint::capture {

struct PixelCoord {
    double u = 0, v = 0;
};

struct Intrinsics {
    int width = 0, height = 0;  // pixels
    double fx = 0, fy = 0;      // focal lengths, pixels
    double cx = 0, cy = 0;      // principal point, pixels (OpenCV: centres at integers)
    double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;  // OpenCV distortion

    // A distortion-free camera of the given horizontal field of view, principal point at the
    // image centre, square pixels.
    static Intrinsics from_fov(int width, int height, double horizontal_fov_rad);
};

// OpenCV's distortion of normalised coordinates (x, y) -> (xd, yd).
void distort(const Intrinsics& k, double x, double y, double& xd, double& yd);
// The inverse: the fixed-point iteration of cv::undistortPoints, finished by Newton's steps where
// it has not converged (the corners of wide lenses). Inside the image of a usable calibration
// (check_calibration_usable: the radial curve does not turn back) the solution is unique.
void undistort(const Intrinsics& k, double xd, double yd, double& x, double& y);

// Pixel of a camera-frame direction, or nullopt when it is behind the camera (Z >= 0) or
// projects outside the image by more than `margin` pixels.
std::optional<PixelCoord> project(const Intrinsics& k, const glm::dvec3& camera_dir, double margin = 0.0);
// Unit camera-frame direction of a pixel (u, v).
glm::dvec3 pixel_ray(const Intrinsics& k, double u, double v);
// Cosine of the widest angle between the optical axis (-Z) and any pixel centre's ray: a
// frustum cull bound.
double min_cos_to_axis(const Intrinsics& k);

// Relative transmittance of the lens over the image, V(r) = 1 + a1 r^2 + a2 r^4 + a3 r^6, with r
// the distance from the principal point divided by the half diagonal (0 at the centre, ~1 in
// the corners). V(0) = 1.
struct Vignetting {
    double a1 = 0, a2 = 0, a3 = 0;
    double at(const Intrinsics& k, double u, double v) const;
};

// The camera's response: code value Z in 0..255 of a relative exposure X (X = 1 just saturates).
// inverse[Z] is the exposure that gives code Z (the centre of its bin); the simulator's forward
// curve is the parametric one below, and a calibrated camera has only the table.
struct Response {
    std::array<double, 256> inverse{};  // strictly increasing from inverse[0] >= 0

    // Z = 255 * (1 + c) * X^(1/g) / (X^(1/g) + c), clamped to 255: gamma-like, with a shoulder.
    static Response parametric(double gamma = 2.2, double shoulder = 0.25);
    double gamma = 0, shoulder = 0;  // the parameters when parametric (0: a table only)
    // The parametric forward curve (real-valued, before quantisation); only when parametric.
    double forward(double exposure) const;
};

// Robertson-style weight of a code value: near 0 for codes close to 0 or 255, where noise or
// clipping make the exposure unreliable; exactly 0 at 0 and 255.
double code_weight(int z);

// A modelled rolling-shutter sensor's limits (`glint simulate --sensor-limits`): a shortest
// exposure of 20 microseconds (at the simulator's 6e5 electrons per unit radiance per second and
// a full well of 6000, radiance 500 saturates at gain 1 in the centre of the image) and 2 % of
// the light in a Gaussian glare halo of 1 degree. A calibration without them (the default, and
// every file written before 2026-12-02) has no shortest exposure and no glare: the estimate of
// a source still clipped at the shortest exposure is not reliable yet (docs/capture.md,
// "Estimated sources": sunset's sun clips and its sky's glow is taken for glare).
inline constexpr double kModelledMinExposureS = 20e-6;
inline constexpr double kModelledGlareFraction = 0.02;
inline constexpr double kModelledGlareSigmaRad = 0.017453292519943295;

// Everything stored per camera (docs/capture.md "Calibration").
struct CameraCalibration {
    Intrinsics intrinsics;
    Vignetting vignetting;
    Response response = Response::parametric();
    glm::dquat sensor_from_camera{1, 0, 0, 0};  // alignment: camera vectors -> sensor frame
    double time_offset_s = 0;  // camera timestamp + offset = sensor time of the same instant
    // Relative exposure per unit radiance per second at gain 1: divides it out, so maps come out
    // in radiance units. Photometric calibration is not built; 1 gives relative radiance.
    double sensitivity = 1;
    // The sensor's shortest exposure time, seconds (docs/capture.md "Camera model"). A real rolling
    // shutter has one of tens of microseconds; the sun clips even there. The simulator clamps to it;
    // the accumulator knows that a region still clipped in a frame this short cannot be measured by
    // a shorter one and estimates its energy instead (hdr_accumulator.hpp). Not stored by
    // 0: no limit. Stored as calibration.json's "shortest_exposure_s".
    double min_exposure_s = 0;
    // The lens's point spread beyond the pixel: a share `glare_fraction` of the light reaching a
    // pixel is spread as a Gaussian of `glare_sigma_rad` (veiling glare), the rest stays. What
    // makes a source still clipped at the shortest exposure measurable: its halo, unclipped, is
    // proportional to its energy (hdr_accumulator.hpp "Estimated sources"). 0: none. Stored as
    // calibration.json's "glare": {"fraction", "sigma_rad"}.
    double glare_fraction = 0;
    double glare_sigma_rad = kModelledGlareSigmaRad;
    // The rolling shutter: seconds from the start of the first row's exposure to the start of the
    // last row's plus one row (rows are read out top to bottom, readout_s / height apart). Row v's
    // exposure is centred row_time_offset_s(v) after the frame's timestamp, which is the middle
    // row's mid-exposure. 0: a global shutter (and every file written before 2026-12-02). Stored
    // as calibration.json's "readout_s".
    double readout_s = 0;
    // The sensor's noise in relative exposure X (docs/render.md, "Matching the camera"): shot noise
    // of X x full_well_electrons / gain photo-electrons and a read noise of standard deviation
    // noise_read, i.e. variance X gain / full_well + read^2. Used to give virtual pixels the
    // video's noise; a sensor's datasheet gives both, or `glint calibrate noise` fits them to a bracket.
    // 0: unknown. Stored as calibration.json's "noise": {"full_well_electrons", "read_noise"}.
    double noise_full_well_electrons = 0;
    double noise_read = 0;
    double row_time_offset_s(double v) const {
        return intrinsics.height > 0 ? readout_s * (v - 0.5 * (intrinsics.height - 1)) / intrinsics.height : 0.0;
    }
};

// The simulated sensor's readout time (`glint simulate`, unless --readout-ms): a Sony IMX219 (the
// Pi camera v2) in its 1920x1080 mode reads a line in 3448 pixel clocks at 182.4 MHz, 18.9 us, so
// 1080 lines in 20.4 ms; frames scaled down from that mode keep its readout time.
inline constexpr double kModelledReadoutS = 0.020;

}  // namespace glint::capture
