// The guided-capture logic of the kiosk (no drawing: the kiosk's UI, not built yet, draws what this decides).
// Fed after every accumulated frame, it says where the visitor should point next, whether they
// turn too fast for a sharp frame, whether the exposure is usable, how far along the capture is,
// and when it is done (enough of the sphere covered, or the time limit).
//
// - Target: the centre of the 0.5 rad cap holding the most unseen solid angle (coverage.hpp),
//   ignoring what cannot be seen: everything below `floor_elevation_deg` (the stand, the
//   visitor's feet; filled by the coverage rule instead).
// - Too fast: the blur a frame would get, angular speed x exposure time x focal length in pixels,
//   above `max_blur_px`.
// - Exposure: more than `max_clipped_share` of the pixels at code 255 in some channel is too
//   bright (the camera should shorten the exposure or the capture bracket); a mean code below
//   `min_mean_code` is too dark.
// - Progress: coverage of the seeable part / the target coverage, capped at 1.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "appliance/capture/camera_frame.hpp"
#include "appliance/capture/camera_model.hpp"
#include "appliance/capture/coverage.hpp"

namespace glint::capture {

struct GuidedSettings {
    double target_coverage = 0.95;     // of the seeable sphere
    double time_limit_s = 90;
    double floor_elevation_deg = -78;  // below this nothing is expected to be seen
    double max_blur_px = 2.0;
    double max_clipped_share = 0.02;
    double min_mean_code = 25;
    int min_samples = 1;
    // A gap between two of the scan's frames longer than this is the scan waiting (the kiosk
    // feeds no frames while the sensor or the camera is lost) and does not count against the time
    // limit. Several frame periods of a slow (3 fps) scan with frames rejected for blur.
    double pause_after_gap_s = 1.5;
};

enum class GuidedState : std::uint8_t { Scanning, Complete, TimedOut };
enum class ExposureStatus : std::uint8_t { Ok, TooBright, TooDark };
const char* guided_state_name(GuidedState s);
const char* exposure_status_name(ExposureStatus s);

struct GuidedStep {
    GuidedState state = GuidedState::Scanning;
    glm::dvec3 next_target{0, 0, -1};  // world direction to point the camera at next
    double turn_to_target_deg = 0; // angle between the camera's axis and the target
    double progress = 0;           // 0..1
    double seeable_coverage = 0;   // covered share of the sphere above the floor limit
    double angular_speed_deg_s = 0;
    double blur_px = 0;
    bool too_fast = false;
    ExposureStatus exposure = ExposureStatus::Ok;
    double clipped_share = 0, mean_code = 0;
    double elapsed_s = 0;
};

class GuidedCapture {
public:
    GuidedCapture(GuidedSettings settings, Intrinsics camera);

    // One frame: its time and exposure, the camera orientation it was accumulated with, and the
    // per-texel samples after it (HdrAccumulator::samples()).
    GuidedStep update(const CameraFrame& frame, const glm::dquat& world_from_camera,
                      const std::vector<std::uint32_t>& samples, int map_width, int map_height);

    // A frame the capture could not place (no orientation: the sensor lost, replugging): the
    // scan is paused from it until the next placed frame, and that time does not count against
    // the time limit (the visitor is waiting for the sensor, not scanning).
    void frame_unplaced(std::int64_t t_ns);
    double paused_s() const { return double(paused_ns_) * 1e-9; }

    const GuidedStep& last() const { return last_; }

private:
    GuidedSettings settings_;
    Intrinsics camera_;
    std::optional<std::int64_t> start_ns_;
    std::optional<std::int64_t> previous_t_ns_;
    std::optional<std::int64_t> last_t_ns_;       // the last placed frame's time
    glm::dquat previous_q_{1, 0, 0, 0};
    std::optional<std::int64_t> paused_from_ns_;  // the first unplaced frame since the last placed one
    std::int64_t paused_ns_ = 0;                  // time spent paused, excluded from elapsed_s
    GuidedStep last_;
};

}  // namespace glint::capture
