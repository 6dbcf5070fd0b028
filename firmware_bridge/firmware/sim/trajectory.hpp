// True orientation of the simulated board over time, from a trajectory file or a built-in.
//
// File format (text, one sample per line; see README.md "Trajectory files"):
//   # comment lines and blank lines are ignored
//   format quaternion          (or: format ypr_deg) -- first non-comment line
//   0, 1, 0, 0, 0              time_us, w, x, y, z        (quaternion: sensor -> world)
//   0, 90, 10, 0               time_us, yaw, pitch, roll  (ypr_deg: degrees)
// Fields are separated by commas and/or spaces. Times are microseconds from the start of the
// simulation, strictly increasing, the first one 0. Between samples the orientation is
// interpolated by slerp (constant angular velocity); after the last sample it stays put.
// ypr_deg: q = Ry(yaw) Rx(pitch) Rz(roll), intrinsic: yaw about world +Y (positive turns the
// sensor's -Z from north towards west, i.e. left), then pitch about the sensor's +X (positive
// raises -Z), then roll about the sensor's +Z (positive lifts the +X side).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "firmware_bridge/firmware/rotation.hpp"

namespace glint::firmware::sim {

struct TrajectorySample {
    std::uint64_t time_us = 0;
    Quatd world_from_sensor;
};

struct MotionState {
    Quatd world_from_sensor;     // rotation sensor -> world (+Y up, -Z north)
    Vec3d angular_rate_rad_s;    // angular velocity in the sensor frame (what a gyro measures)
};

Quatd quat_from_ypr_deg(double yaw_deg, double pitch_deg, double roll_deg);

class Trajectory {
public:
    // Samples must be strictly increasing in time, starting at 0; at least one.
    explicit Trajectory(std::vector<TrajectorySample> samples);

    // Reads a trajectory file; throws std::runtime_error naming "file:line" and the problem.
    static Trajectory load(const std::string& path);
    // Parses trajectory text; `source_name` is used in error messages ("name:line: ...").
    static Trajectory parse(const std::string& text, const std::string& source_name);
    // Built-in trajectories: "static", "yaw-sweep", "tumble", "kiosk" (README.md lists them):
    // one period, looping.
    static Trajectory builtin(const std::string& name);
    static std::vector<std::string> builtin_names();

    // Repeat the trajectory after its last sample (time modulo the last sample's time) instead
    // of holding the last orientation. Built-ins are one period long and loop.
    void set_loop(bool loop) { loop_ = loop && samples_.back().time_us > 0; }
    bool loops() const { return loop_; }

    MotionState at(std::uint64_t time_us) const;
    std::uint64_t end_us() const { return samples_.back().time_us; }
    const std::vector<TrajectorySample>& samples() const { return samples_; }

private:
    std::vector<TrajectorySample> samples_;
    bool loop_ = false;
};

}  // namespace glint::firmware::sim
