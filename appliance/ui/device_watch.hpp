// Watching the kiosk's devices from what arrives each frame (docs/kiosk.md, "Devices that
// misbehave"): a camera that stops delivering is restarted, again and again until it delivers; an
// orientation stream that falls silent is "sensor lost" (the scan pauses and the visitor is asked
// to wait); frames that arrive out of order are dropped. No I/O: the kiosk loop feeds it the
// counts and carries out what it says, so the rules are unit-tested apart from any device.
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

namespace glint::ui {

struct DeviceWatchSettings {
    // No camera frame for this long: the camera is lost and restarted, then again every as long
    // while it stays silent. Longer than any gap of a working camera, recorded sessions included
    // (the shipped kiosk session has 2.2 s between its scan and its AR phase).
    double camera_stall_s = 3.0;
    // No orientation sample for this long: the sensor is lost. Long enough for a few lost frames
    // of a 100-200 Hz stream, short enough that a visitor is told within a moment.
    double sensor_lost_after_s = 0.5;
};

class DeviceWatch {
public:
    explicit DeviceWatch(DeviceWatchSettings settings = {}, double start_s = 0);

    // A camera frame's capture time (ns): true to take it, false when it is not after the last
    // frame taken (out of order or repeated: the capture and the tracker need time order).
    bool accept_frame(std::int64_t t_ns);

    struct Step {
        bool restart_camera = false;     // carry it out, then report with camera_restarted()
        std::vector<std::string> log;    // what changed, for the journal
    };
    // One kiosk frame at t_s: how many camera frames and orientation samples arrived since the last.
    Step update(double t_s, std::size_t frames, std::size_t samples);
    // The outcome of a restart update() asked for: "" when the camera started, else why not.
    std::string camera_restarted(double t_s, const std::string& error);

    bool camera_lost() const { return camera_lost_; }
    bool sensor_lost() const { return sensor_lost_; }
    double camera_fps() const;      // frames in the last second
    double sensor_rate_hz() const;  // samples in the last second

    struct Counts {
        std::uint64_t camera_restarts = 0, camera_restart_failures = 0, camera_losses = 0, sensor_losses = 0;
        std::uint64_t frames_out_of_order = 0;
        double camera_lost_s = 0, sensor_lost_s = 0;  // total time lost, closed episodes
    };
    const Counts& counts() const { return counts_; }

private:
    DeviceWatchSettings settings_;
    double t_s_ = 0, last_frame_s_ = 0, last_sample_s_ = 0, last_restart_s_ = -1e300;
    double camera_lost_since_s_ = 0, sensor_lost_since_s_ = 0;
    bool camera_lost_ = false, sensor_lost_ = false;
    bool have_frame_time_ = false;
    std::int64_t last_frame_t_ns_ = 0;
    std::uint64_t next_out_of_order_log_ = 1;
    std::deque<std::pair<double, std::size_t>> frames_window_, samples_window_;  // (t_s, count) of the last second
    Counts counts_;
};

}  // namespace glint::ui
