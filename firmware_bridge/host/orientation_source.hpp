// OrientationSource: the one interface through which the appliance learns where the camera
// points. Every driver (serial sensor board, I2C BNO055, Modbus pan/tilt head, a recorded file)
// derives from it, runs its own reader thread, and calls publish() with orientations already in
// the world frame of docs/conventions.md and on the appliance's monotonic clock. Consumers either
// take every sample as it arrives (set_sample_callback) or ask for the orientation at any time
// (orientation_at: slerp between the samples around it), and read health() at any time.
//
// Times: every *_ns here is the appliance's CLOCK_MONOTONIC in nanoseconds (in tests and replay,
// the virtual clock passed in). The latency offset models a fixed delay of the whole sensor path
// (fusion filter lag, transport): a sample published with time t is stored as t - latency, i.e.
// "what the sensor reports now was true `latency` ago". It is calibrated against the camera
// (`glint calibrate alignment`, docs/capture.md) and configured per device.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <string>

#include "firmware_bridge/host/orientation_history.hpp"
#include "firmware_bridge/host/clock.hpp"

namespace glint::host {

// A source cannot be set up at all (bad path syntax, bad option): thrown by constructors and
// start(). Faults of a running link (device gone, garbage, timeouts) never throw: they show in
// health() and the driver keeps trying.
class SourceError : public std::runtime_error {
    using std::runtime_error::runtime_error;
};

enum class LinkState : std::uint8_t {
    Stopped,       // start() not called, or stop() called
    Connecting,    // opening the device or waiting for the first sample
    Streaming,     // samples arrive
    Stalled,       // the link is open but no sample for longer than the stall limit
    Disconnected,  // the device vanished or failed; reopening with back-off
    Finished,      // a finite source (a recording) reached its end
};
const char* link_state_name(LinkState state);

struct LinkHealth {
    LinkState state = LinkState::Stopped;
    double rate_hz = 0;                    // samples published during the last second
    std::int64_t last_sample_age_ns = -1;  // now - arrival time of the newest sample; -1: none yet
    std::uint64_t samples = 0;             // samples published since start()
    std::uint64_t crc_errors = 0;          // frames rejected by their CRC (serial)
    std::uint64_t frame_errors = 0;        // other rejected frames: COBS, length, version, type, value
    std::uint64_t lost_frames = 0;         // frames missing by sequence number
    std::uint64_t timeouts = 0;            // requests without an answer in time (I2C, Modbus)
    std::uint64_t reconnects = 0;          // times the device was reopened after a loss
    std::uint64_t stalls = 0;              // times the stream fell silent past the stall limit (kept by the base)
    // Samples dropped because the board-clock estimate placed them at or before an earlier one:
    // a backlog read all at once (e.g. right after opening the port) cannot be timed; not an error.
    std::uint64_t untimed_samples = 0;
    double clock_drift_ppm = 0;            // board clock rate minus appliance clock rate (serial)
    std::string last_error;                // the latest fault, naming the device; "" when none
};

struct SourceOptions {
    std::size_t history_capacity = 1024;        // samples kept for orientation_at()
    std::int64_t max_gap_ns = 100'000'000;      // neighbours further apart are not interpolated
    std::int64_t max_hold_ns = 20'000'000;      // newest sample still answered this long after it
    std::int64_t latency_offset_ns = 0;         // see the file comment
    std::int64_t stall_after_ns = 200'000'000;  // silence that counts as a stalled stream
};

class OrientationSource {
public:
    using SampleCallback = std::function<void(const OrientationSample&)>;

    OrientationSource(std::string name, recording::Clock& clock, SourceOptions options = {});
    virtual ~OrientationSource() = default;
    OrientationSource(const OrientationSource&) = delete;
    OrientationSource& operator=(const OrientationSource&) = delete;

    // Opens the device and starts the reader thread. Throws SourceError only for a configuration
    // that can never work; a missing or failing device is retried (health() says why).
    virtual void start() = 0;
    // Stops the thread and closes the device. Idempotent. Derived destructors must call it.
    virtual void stop() = 0;

    // "serial:/dev/ttyACM0", "replay:session.glrec", ...: the spec the source was made from.
    const std::string& name() const { return name_; }

    // Called on the reader thread for every published sample, after it entered the history.
    // Set before start(); must be quick (it delays the next read).
    void set_sample_callback(SampleCallback callback);

    // The orientation at appliance time t_ns, interpolated (see OrientationHistory).
    HistoryAnswer orientation_at(std::int64_t t_ns) const;
    std::optional<OrientationSample> newest() const;

    // A snapshot of the counters, with rate, age and the stalled state computed for now.
    LinkHealth health() const;

    const SourceOptions& options() const { return options_; }

protected:
    // For the driver's thread. publish(): s.t_ns is the sensor time mapped to the appliance
    // clock; the latency offset is applied here. Returns false for a sample out of time order
    // (dropped and counted as a frame error: it cannot be interpolated).
    bool publish(OrientationSample s);
    // Edits the driver-owned counters and state under the lock.
    void edit_health(const std::function<void(LinkHealth&)>& edit);
    void set_state(LinkState state);
    void note_error(std::string message);  // last_error = message
    // For a driver loop that waits with a timeout: counts a stall now even if nobody reads health().
    void check_stall() const { (void)health(); }
    recording::Clock& clock() const { return clock_; }
    std::int64_t now_ns() const { return static_cast<std::int64_t>(clock_.now_us()) * 1000; }

private:
    std::string name_;
    recording::Clock& clock_;
    SourceOptions options_;
    mutable std::mutex mutex_;
    OrientationHistory history_;
    LinkHealth health_;
    std::deque<std::int64_t> recent_arrivals_ns_;  // arrivals within the last second (rate)
    std::int64_t last_arrival_ns_ = -1;
    // Stall accounting is updated by health() too (a const reader may be the first to notice).
    mutable bool stall_counted_ = true;  // the current silence was already counted
    mutable std::uint64_t stalls_ = 0;
    SampleCallback callback_;
};

}  // namespace glint::host
