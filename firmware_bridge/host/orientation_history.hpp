// The recent past of one orientation stream: a fixed-capacity ring of timestamped orientations
// with interpolation to any time inside it. A capture frame asks "where did the camera point at
// the frame's exposure midpoint?"; the answer is the slerp between the two samples around that
// time (constant angular velocity between samples, which is what a 100+ Hz sensor resolves).
//
// Not thread-safe by itself; OrientationSource guards it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "firmware_bridge/firmware/rotation.hpp"

namespace glint::host {

using Quatd = firmware::Quatd;

// One orientation of the sensor frame in the world frame of docs/conventions.md (+Y up, -Z
// forward): v_world = q v_sensor q*.
struct OrientationSample {
    std::int64_t t_ns = 0;       // appliance CLOCK_MONOTONIC, nanoseconds, when q was true
    Quatd q;                     // unit, w >= 0
    std::uint64_t board_us = 0;  // the board's own timestamp (µs since board reset); 0 if none
};

enum class Lookup : std::uint8_t {
    Interpolated,  // between two samples no further apart than the gap limit
    Exact,         // t equals a sample's time
    BeforeFirst,   // older than the oldest sample kept: no answer
    AfterLast,     // newer than the newest sample: held for at most the hold limit, else no answer
    Gap,           // the samples around t are further apart than the gap limit: no answer
};

struct HistoryAnswer {
    std::optional<Quatd> q;
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
