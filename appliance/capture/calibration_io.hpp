// The stored camera calibration (docs/capture.md "Calibration file"): versioned JSON, written
// atomically, read with errors that name the file and the key.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "appliance/capture/camera_model.hpp"

namespace glint::capture {

inline constexpr int kCalibrationVersion = 1;

std::string calibration_to_json(const CameraCalibration& calibration);
// Throws InputError "FILE: key 'k': reason" (the file name is `source`).
CameraCalibration calibration_from_json(const std::string& text, const std::string& source);

// Throws InputError naming `source` and the key where a calibration would not load again: a
// vignetting falloff outside 0.05-20 in the image, a radial distortion that turns back before its
// farthest corner. For a calibration about to be put in force (glint calibrate, the menu's
// wizards), so that the kiosk is never left with one it cannot start on.
void check_calibration_usable(const CameraCalibration& calibration, const std::string& source);

// Writes `path` atomically; when `path` is a state item (docs/state.md: the state directory's
// calibration.json saved by save_state_calibration) it saves a new checksummed version of it.
void save_calibration(const std::filesystem::path& path, const CameraCalibration& calibration);
// Reads and checks `path`. When it is a state item (the state directory's calibration.json, as
// glint run reads it) it is verified against its checksum too; a faulty one is set aside into
// <dir>/corrupt/ and the InputError says why and where it went.
CameraCalibration load_calibration(const std::filesystem::path& path);

// The appliance's own calibration, <state_dir>/calibration.json, as a state item
// (core/state_store.hpp): saved with a checksum (throws state::SaveError naming the file, the old
// version kept), loaded only when it verifies and parses. A faulty one is set aside into
// <state_dir>/corrupt/ and logged, and nullopt returned (the caller's default: no calibration).
// A calibration.json copied in by hand (no checksum) is loaded if it parses, and logged as
// unverified.
inline constexpr const char* kStateCalibrationName = "calibration.json";
void save_state_calibration(const std::filesystem::path& state_dir, const CameraCalibration& calibration);
std::optional<CameraCalibration> load_state_calibration(const std::filesystem::path& state_dir,
                                                        const std::function<void(const std::string&)>& log);

}  // namespace glint::capture
