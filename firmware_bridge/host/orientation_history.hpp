// The recent past of one orientation stream: a fixed-capacity ring of timestamped orientations
// with interpolation to any time inside it. A capture frame asks "where did the camera point at
// the frame's exposure midpoint?"; the answer is the slerp between the two samples around that
// time (constant angular velocity between samples, which is what a 100+ Hz sensor resolves).
//
// Orientations are the appliance's glm::dquat from here on: a driver turns the sensor side's
// quaternions (firmware_bridge/firmware/rotation.hpp) into one with to_glm, once, when it makes
// the sample.
//
// Not thread-safe by itself; OrientationSource guards it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <glm/gtc/quaternion.hpp>
#include <optional>
#include <vector>

namespace glint::firmware {
template <typename T>
struct Quat;
}  // namespace glint::firmware
namespace glint::protocol {
struct Orientation;
}  // namespace glint::protocol

namespace glint::host {

// The one conversion of the sensor side's quaternions into the appliance's: unit, w >= 0 (a zero
// or non-finite input gives the identity).
glm::dquat to_glm(const firmware::Quat<double>& q);
// The same for a protocol Orientation message's Q30 quaternion (world_from_sensor).
glm::dquat to_glm(const protocol::Orientation& message);

// One orientation of the sensor frame in the world frame of docs/conventions.md (+Y up, -Z
// forward): v_world = world_from_sensor * v_sensor.
struct OrientationSample {
    std::int64_t t_ns = 0;                     // appliance CLOCK_MONOTONIC, nanoseconds, when it was true
    glm::dquat world_from_sensor{1, 0, 0, 0};  // unit, w >= 0 (made by to_glm)
    std::uint64_t board_us = 0;                // the board's own timestamp (µs since board reset); 0 if none
};

enum class Lookup : std::uint8_t {
    Interpolated,  // between two samples no further apart than the gap limit
    Exact,         // t equals a sample's time
    BeforeFirst,   // older than the oldest sample kept: no answer
    AfterLast,     // newer than the newest sample: held for at most the hold limit, else no answer
    Gap,           // the samples around t are further apart than the gap limit: no answer
};

struct HistoryAnswer {
    // A sample's, or glm::slerp between two (the short way; either sign).
    std::optional<glm::dquat> world_from_sensor;
    Lookup lookup = Lookup::BeforeFirst;
};

class OrientationHistory {
public:
    // capacity: samples kept (e.g. 2 s at 200 Hz = 400). max_gap_ns: two neighbours further apart
    // than this are not interpolated (the stream was lost in between). max_hold_ns: how long past
    // the newest sample it is still returned as is.
    explicit OrientationHistory(std::size_t capacity = 1024, std::int64_t max_gap_ns = 100'000'000,
                                std::int64_t max_hold_ns = 20'000'000);

    // Appends a sample. Samples must come in time order: one at or before the newest is dropped
    // (returns false), so a clock-mapping hiccup cannot fold the timeline back on itself.
    bool push(const OrientationSample& sample);

    HistoryAnswer at(std::int64_t t_ns) const;

    std::size_t size() const { return size_; }
    bool empty() const { return size_ == 0; }
    std::optional<OrientationSample> newest() const;
    std::optional<OrientationSample> oldest() const;
    void clear() { size_ = 0; head_ = 0; }

private:
    const OrientationSample& nth(std::size_t i) const;  // 0 = oldest

    std::vector<OrientationSample> ring_;
    std::size_t head_ = 0;  // index of the next write
    std::size_t size_ = 0;
    std::int64_t max_gap_ns_;
    std::int64_t max_hold_ns_;
};

}  // namespace glint::host
