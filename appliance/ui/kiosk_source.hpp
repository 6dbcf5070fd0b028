// Where the kiosk's inputs come from (docs/kiosk.md, "One program, two entry points"): a recorded
// session (kiosk_replay.hpp) or the live camera, orientation sensor and buttons (`glint run`,
// appliance/app/run_command.cpp). The kiosk loop (kiosk_loop.hpp) is the same for both.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "appliance/capture/camera_frame.hpp"
#include "appliance/capture/camera_model.hpp"
#include "appliance/capture/capture_pipeline.hpp"
#include "appliance/capture/kiosk_session.hpp"
#include "appliance/render/camera_response.hpp"
#include "appliance/ui/screen_model.hpp"

namespace glint::ui {

// What arrived up to a time (appliance clock, ns), each list in time order.
struct KioskPoll {
    std::vector<capture::CameraFrame> frames;
    std::vector<capture::SensorOrientation> orientations;
    std::vector<capture::SessionEvent> events;  // "button"/"press", "key"/"<keysym>", ...
};

// The devices' own account of themselves, for the maintenance menu's status page.
struct SourceHealth {
    std::string sensor = "ok";  // the orientation link: "streaming", "disconnected: hang-up (device unplugged?)", ...
    double sensor_rate_hz = 0;  // as the link counts it (samples in the last second)
    std::string camera_error;   // the camera's last error ("" = none)
};

class KioskSource {
public:
    virtual ~KioskSource() = default;
    virtual std::string describe() const = 0;
    virtual const capture::CameraCalibration& calibration() const = 0;
    virtual const render::CameraResponse& response() const = 0;
    // The board on the table (board JSON, tracking/board.hpp); "" = the default board.
    virtual std::string board_json() const { return {}; }
    // Fills what the capture needs to know of this source: a session directory (replay) or the
    // live calibration and orientation lookup.
    virtual void configure_capture(capture::CaptureOptions& options) = 0;
    // The kiosk's time 0 (appliance clock, ns).
    virtual std::int64_t start_ns() const = 0;
    // Everything that arrived up to now_ns since the last poll.
    virtual KioskPoll poll(std::int64_t now_ns) = 0;
    // The sensor's orientation at a sensor time (nullopt: none known there).
    virtual std::optional<glm::dquat> world_from_sensor(std::int64_t sensor_t_ns) const = 0;
    // No more input will come (a replay past its last frame; live: never).
    virtual bool ended(std::int64_t now_ns) const = 0;

    // The visitor's scan starts (true) or ends (false): a live camera's exposure is then driven
    // by the capture's exposure controller (brackets of the clipped views), and handed back to
    // the camera's own automatic exposure after. A replay's exposures are recorded: nothing to do.
    virtual void set_scanning(bool) {}
    // The exposure control's state for the screen ("" = none; "bracketing" while it brackets).
    virtual std::string exposure_state() const { return {}; }
    // The camera stopped delivering frames: stop it and start it again. "" when it started, else
    // why not (the kiosk keeps trying). A replay has nothing to restart.
    virtual std::string restart_camera() { return {}; }
    virtual SourceHealth health() const { return {}; }
    // The button's lamp (GPIO output; nothing without one).
    virtual void set_lamp(LampMode) {}

    // A replay: the clock is the loop's own (one frame period a frame), the capture takes in each
    // frame before the guide is asked; live: the wall clock.
    virtual bool replayed() const { return false; }
    // A recorded scan's end (the recorded visitor stopped turning): CAPTURE ends there too.
    virtual std::optional<std::int64_t> scan_end_ns() const { return std::nullopt; }
    // Whether a frame belongs to a recorded AR phase (tracking figures count only those).
    virtual bool in_ar_phase(std::int64_t) const { return true; }
    // A simulated session's true board pose of a frame.
    virtual std::optional<capture::TruthBoardPose> truth_board(std::uint64_t) const { return std::nullopt; }
    // A simulated session's true world_from_camera of a frame (truth/camera.csv).
    virtual std::optional<glm::dquat> truth_camera(std::uint64_t) const { return std::nullopt; }
};

}  // namespace glint::ui
