// What version N of each state item holds, for the fault tests (tests/faults): the writer saves
// these through the appliance's own code paths, and the checker compares what it finds on disk
// with them byte for byte or texel for texel, not only against the checksum.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "appliance/capture/camera_model.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::faults {

inline constexpr const char* kSettingsItem = "settings.toml";  // a config written into the state directory
inline constexpr const char* kPinLockItem = "pin-lock.json";
inline constexpr const char* kSceneItem = "scene";
// A SHA-512 crypt(3) hash of "1234" at 1000 rounds (the fewest libxcrypt takes): a wrong PIN costs
// about a millisecond, so that the writer saves the PIN lock often (yescrypt takes ~20 ms).
inline constexpr const char* kFastPinHash =
    "$6$rounds=1000$glintfaults$ASWLz8PMM3K5A.TnVWaZUMRDXCMJO3WvDXbnyz4F2gMZ6YOBEz5L4ZbSiCM/TrINwFhkIEH0WgiVRct0hv01L1";
inline constexpr const char* kBootId = "faults-boot";

// The scene's environment map and coverage of version v (v < 2^24: exact in float). Texel (0, 0)
// holds v, the rest a pattern of v, so that any mix of two versions differs.
HdrImage scene_env(std::uint64_t v, int width = 64, int height = 32);
HdrImage scene_coverage(std::uint64_t v, int width = 64, int height = 32);
capture::CameraCalibration calibration_version(std::uint64_t v);
std::string settings_version(std::uint64_t v);
std::string pin_lock_text(int failures);

// Version on disk of each item as the appliance's loaders read it; nullopt: none saved yet. A
// fault (a set-aside, content that matches no version) is appended to `problems`.
struct ItemVersions {
    std::optional<std::uint64_t> scene, calibration, settings, pin;
};
ItemVersions read_versions(const std::filesystem::path& state_dir, std::string& problems,
                           const std::function<void(const std::string&)>& log);

// The writer: saves version after version of every item through the real code paths (the scene
// as the kiosk does: the capture's files in the staging directory, then take_captured_scene), and
// writes one line to `report_fd` once its start-up reads are done ("ready") and after each save ("round V", "scene V", "calibration V",
// "settings V", "pin N"). Runs until killed, or for `rounds` rounds when rounds > 0. Continues
// from the versions on disk.
int run_writer(const std::filesystem::path& state_dir, int report_fd, long long rounds);

}  // namespace glint::faults
