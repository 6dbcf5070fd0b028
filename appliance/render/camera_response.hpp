// The camera's response for the renderer (docs/render.md, "Camera response"): the object's HDR
// radiance times the camera's exposure and gain through the calibrated response curve, so that
// it matches the video, and the video's codes back to relative exposure (an image background).
//
// The curve is the capture calibration's (appliance/capture/camera_model.hpp, Response;
// calibration.json's "response" and "sensitivity"): the relative exposure of a pixel is
//   X = radiance x exposure_s x gain x sensitivity        (X = 1 just saturates)
// and its code value Z = forward(X), rounded, clamped to 0..255. The file is read here, not
// through capture's reader: the renderer's layer may not depend on capture, and `glint render`
// links no OpenCV (docs/architecture.md). The sensor's noise, when the file has it, can be matched
// on virtual pixels (Renderer::set_camera_match); vignetting is not applied.
#pragma once

#include <array>
#include <filesystem>
#include <string>

namespace glint::render {

struct CameraResponse {
    // inverse[z]: the relative exposure whose code is z (the centre of its bin), increasing.
    std::array<double, 256> inverse{};
    // The parametric curve's parameters when the calibration has them (the simulator's camera:
    // Z = 255 (1 + c) X^(1/g) / (X^(1/g) + c)); 0 when only the table is known.
    double gamma = 0, shoulder = 0;
    double sensitivity = 1;  // X per unit radiance per second at gain 1
    // The sensor's noise when the calibration has it ("noise"; 0: unknown): the variance of X is
    // X gain / full_well_electrons + read_noise^2.
    double full_well_electrons = 0, read_noise = 0;
    std::string source;      // the file, for messages

    bool has_noise() const { return full_well_electrons > 0; }
    bool parametric() const { return gamma > 0 && shoulder > 0; }
    // The real-valued code of a relative exposure, 0..255: the parametric curve when known, else
    // the table inverted piecewise linearly between its points (inverse[z], z).
    double code(double exposure) const;
    // The relative exposure of an integer code: inverse[z].
    double exposure_of_code(int z) const { return inverse[std::size_t(z < 0 ? 0 : z > 255 ? 255 : z)]; }
};

// Reads calibration.json (format "glint-camera-calibration", as `glint calibrate` and `glint
// simulate` write it): response.inverse (256 increasing numbers >= 0), response.gamma,
// response.shoulder, sensitivity (> 0). Throws InputError naming the file (and `flag`) and the key.
CameraResponse load_camera_response(const std::filesystem::path& path, const std::string& flag = "--camera");

// The camera's settings for a frame: X = radiance x scale().
struct CameraExposure {
    double exposure_ms = 10;
    double gain = 1;
    double scale(const CameraResponse& r) const { return exposure_ms * 1e-3 * gain * r.sensitivity; }
};

}  // namespace glint::render
