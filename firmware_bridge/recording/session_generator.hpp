// A deterministic synthetic sensor session, written through the real Recorder exactly as a host
// driver would write a live one: a sensor board (Hello, FusionStatus, Orientation of a simple
// rotation, RawImu, Heartbeat, a button press) sending protocol frames over a serial line at
// `baud`, some garbage bytes injected on the line, the bytes read by the appliance in
// random-sized chunks with receive timestamps, each chunk recorded and fed to a FrameDecoder
// whose accepted messages are recorded as decoded messages. Plus one ConfigSet sent by the
// appliance, a GPIO edge and two markers.
//
// Same options, same bytes: the pseudo-random numbers come from std::mt19937_64 (whose output
// the standard fixes) reduced with plain arithmetic, not from the library-specific
// distributions, and the creation time is fixed.
#pragma once

#include <cstdint>
#include <string>

namespace glint::recording {

struct SessionOptions {
    std::uint64_t seed = 1;
    std::uint32_t duration_ms = 4000;          // board time covered by the stream
    std::uint32_t orientation_hz = 100;
    std::uint32_t raw_imu_hz = 50;
    std::uint32_t baud = 115200;               // line rate: 10 bit times per byte (8N1)
    std::uint32_t garbage_period_ms = 400;     // mean time between garbage bursts on the line
    std::uint32_t max_chunk = 64;              // largest read() the appliance makes, bytes
};

struct SessionSummary {
    std::uint64_t frames_sent = 0;      // board frames put on the line
    std::uint64_t garbage_bursts = 0;
    std::uint64_t garbage_bytes = 0;
    std::uint64_t chunks = 0;           // received raw-bytes records
    std::uint64_t decoded = 0;          // messages the live decoder accepted
};

// Writes the session to `path` (replacing it when `overwrite`). Throws RecordingError.
SessionSummary generate_session(const std::string& path, const SessionOptions& options, bool overwrite);

}  // namespace glint::recording
