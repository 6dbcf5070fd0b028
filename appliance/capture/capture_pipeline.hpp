// `glint capture`: a recorded or simulated session -> HDR environment map + coverage map, offline.
// Frames are taken in order; each frame's orientation is the sensor's orientation at the frame's
// time (plus the calibrated time offset), rotated by the calibrated alignment; the frame is
// accumulated on the sphere (hdr_accumulator.hpp); at the end the unseen parts are filled by the
// coverage rule (coverage.hpp) and both maps are saved atomically.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "appliance/capture/coverage.hpp"

namespace glint::capture {

enum class OrientationInput {
    Sensors,  // the session's recorded sensor stream (what the appliance has)
    Truth,    // a simulated session's true camera orientations (isolates the accumulation's error)
};

struct CaptureOptions {
    std::filesystem::path session;
    std::filesystem::path out;  // env.exr; the coverage map goes to <stem>.coverage.exr beside it
    int width = 1024, height = 512;
    OrientationInput orientations = OrientationInput::Sensors;
    bool drift_correction = true;  // not built yet: see docs/capture.md
    int min_samples = 1;
    int threads = 0;
};

struct GroundTruthError {
    double weighted_relative_rms = 0;  // over covered texels, against truth/env.exr at this size
    double median_relative = 0;
    double covered_fraction_compared = 0;
};

struct CaptureSummary {
    int frames_used = 0;
    int frames_without_orientation = 0;
    CoverageReport coverage;
    long long filled_texels = 0;
    std::filesystem::path coverage_path;
    std::optional<GroundTruthError> truth_error;  // simulated sessions only
    std::optional<double> orientation_error_median_deg, orientation_error_max_deg;  // ditto
};

std::filesystem::path coverage_path_for(const std::filesystem::path& env_out);

CaptureSummary run_capture(const CaptureOptions& options,
                           const std::function<void(long long, long long)>& progress = {});

}  // namespace glint::capture
