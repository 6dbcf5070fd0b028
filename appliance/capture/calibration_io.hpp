// The stored camera calibration (docs/capture.md "Calibration file"): versioned JSON, written
// atomically, read with errors that name the file and the key.
#pragma once

#include <filesystem>
#include <string>

#include "appliance/capture/camera_model.hpp"

namespace glint::capture {

inline constexpr int kCalibrationVersion = 1;

std::string calibration_to_json(const CameraCalibration& calibration);
// Throws InputError "FILE: key 'k': reason" (the file name is `source`).
CameraCalibration calibration_from_json(const std::string& text, const std::string& source);

void save_calibration(const std::filesystem::path& path, const CameraCalibration& calibration);
CameraCalibration load_calibration(const std::filesystem::path& path);

}  // namespace glint::capture
