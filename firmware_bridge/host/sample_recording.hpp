// Recording a source that has no byte stream (FORMAT.md 3.2, "Sources without a byte stream").
// An I2C BNO055 is read register by register and a Modbus head poll by poll: there are no frames
// whose bytes a replay could decode again. What such a source published is recorded instead, one
// decoded Orientation message per sample, and a replay publishes exactly those samples
// (ReplaySource, on a file whose transport has no byte stream).
#pragma once

#include <cstdint>
#include <mutex>
#include <optional>
#include <string>

#include "firmware_bridge/host/orientation_history.hpp"
#include "firmware_bridge/host/source_spec.hpp"
#include "firmware_bridge/recording/recorder.hpp"

namespace glint::host {

class SampleRecorder {
public:
    // `latency_offset_ns`: the recorded source's SourceOptions::latency_offset_ns. Its samples
    // arrive with that latency taken off (OrientationSource::publish); the file keeps the times
    // as the driver published them, so that a replay applies its own latency once, as a replay
    // of a serial board's bytes does.
    SampleRecorder(recording::Recorder& recorder, std::int64_t latency_offset_ns)
        : recorder_(recorder), latency_offset_ns_(latency_offset_ns) {}

    // One sample (from the source's sample callback) as a decoded Orientation message: the
    // quaternion in Q30, the board's timestamp (0 when the source has none) and a sequence
    // number of its own. False once the recorder failed (its error() says why).
    bool record(const OrientationSample& sample);

private:
    recording::Recorder& recorder_;
    std::int64_t latency_offset_ns_;
    std::uint16_t seq_ = 0;
};

// How a live source of `spec` is recorded: a serial board's byte stream (serial_board_recording:
// the driver's set_recorder), or an I2C or Modbus source's published samples
// (decoded_sample_recording: a SampleRecorder on its sample callback). nullopt for a replay,
// which is a recording already.
std::optional<recording::RecorderOptions> recording_options_for(const SourceSpec& spec);

class OrientationSource;

// A live source's recording, whatever its kind (`glint sensors --record`, `glint run --record`):
// the file made with recording_options_for(spec), then attach() before the source starts and
// sample() from its sample callback. A serial board's bytes go in from its reader; an I2C or
// Modbus source's published samples through sample() (a SampleRecorder).
class SensorRecording {
public:
    // Throws SourceError for a replay (a recording already), and what recording::Recorder throws
    // (naming the file) when it cannot be created.
    SensorRecording(const std::string& path, const SourceSpec& spec, recording::Clock& clock);
    SensorRecording(const SensorRecording&) = delete;
    SensorRecording& operator=(const SensorRecording&) = delete;

    // `source` was made from the constructor's spec; a serial one must be stopped before this
    // recording is destroyed (it writes through a pointer to it).
    void attach(OrientationSource& source);
    // A sample the attached source published: recorded when the source has no byte stream,
    // ignored otherwise. Thread-safe; after close() it does nothing.
    void sample(const OrientationSample& sample);
    // Writes, syncs and closes the file; false on a failure (error() says which file and why).
    bool close();
    std::string error() const { return recorder_.error(); }

private:
    recording::Recorder recorder_;
    bool serial_;
    std::mutex mutex_;  // samples_ against close(): sample() runs on the source's reader thread
    std::optional<SampleRecorder> samples_;
};

// A decoded Orientation message back as the sample it was recorded from (times in ns of the
// appliance clock, before any latency offset).
OrientationSample sample_from_decoded(std::uint64_t host_time_us, const protocol::Orientation& message);

}  // namespace glint::host
