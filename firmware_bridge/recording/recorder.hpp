// Recorder: appends records to a recording file while the real driver runs.
//
// A host driver calls, from its read loop:
//   recorder.on_bytes(t_us, chunk);                     // every read() result, before decoding
//   decoder.feed_all(chunk, [&](const FrameEvent& e) {
//       recorder.on_sample(t_us, e);                     // same t_us: the chunk that ended the frame
//       ...
//   });
// and recorder.on_gpio(...) for line edges, recorder.mark("capture started") for annotations.
// Records are buffered and written in blocks; data reaches the disk (fdatasync) at the latest
// `sync_interval_us` after it was appended, provided the driver keeps calling (or calls flush());
// close() writes and syncs everything. A torn last record after a power loss is detected and
// skipped by the reader (FORMAT.md "Power loss").
//
// Errors: creating the file throws RecordingError (set-up). After that, no method throws: a
// failed write or sync puts the recorder in the failed state, error() says which file and why
// (errno text), and every later call returns false without touching the file. All methods are
// thread-safe (a serial reader thread and a GPIO thread may share one recorder).
#pragma once

#include <cstddef>
#include <cstdint>
#include <mutex>
#include <span>
#include <string>
#include <string_view>

#include "firmware_bridge/protocol/frame_decoder.hpp"
#include "firmware_bridge/recording/clock.hpp"
#include "firmware_bridge/recording/format.hpp"
#include "firmware_bridge/recording/unique_fd.hpp"

namespace glint::recording {

struct RecorderOptions {
    // Source description. created_unix_us = 0 is filled from CLOCK_REALTIME and
    // created_monotonic_us = 0 from the recorder's clock; set both for a reproducible file.
    // decoded_types: the message types on_sample() keeps (others are ignored), e.g.
    // board_message_types(). format/header_size fields are set by the recorder.
    FileHeader header;
    std::size_t block_size = 64 * 1024;      // buffered bytes that trigger a write()
    std::uint64_t sync_interval_us = 1'000'000;  // longest time appended data stays unsynced
    bool overwrite = false;                  // false: refuse to replace an existing file
};

// The options of a sensor board's serial stream: its device and line rate in the header, the
// board's messages decoded (what `glint sensors --record` and `glint run --record` write).
inline RecorderOptions serial_board_recording(const std::string& device, std::uint32_t baud) {
    RecorderOptions o;
    o.header.transport = Transport::Serial;
    o.header.device = device;
    o.header.baud = baud;
    o.header.decoded_types = board_message_types();
    return o;
}

// The options of a source without a byte stream (an I2C BNO055, a Modbus pan/tilt head): its
// transport and device in the header, and each published sample kept as a decoded Orientation
// message (host::record_sample), which is what a replay of such a file publishes.
inline RecorderOptions decoded_sample_recording(Transport transport, const std::string& device) {
    RecorderOptions o;
    o.header.transport = transport;
    o.header.device = device;
    o.header.decoded_types = {static_cast<std::uint8_t>(protocol::MessageType::Orientation)};
    return o;
}

class Recorder {
public:
    // Creates `path` and writes and syncs the header. Throws RecordingError naming the path.
    Recorder(std::string path, RecorderOptions options, Clock& clock);
    // Closes (and syncs) if close() was not called; an error there is lost, so call close().
    ~Recorder();
    Recorder(const Recorder&) = delete;
    Recorder& operator=(const Recorder&) = delete;

    // Raw transport bytes as one read returned them, time_us = appliance CLOCK_MONOTONIC µs of
    // the read. Chunks above kMaxRawChunk become several records.
    bool on_bytes(std::uint64_t time_us, std::span<const std::uint8_t> bytes,
                  Direction direction = Direction::Received);
    // A decoder event: recorded when its status is Ok and its type is in decoded_types,
    // otherwise ignored (returns true). host_time_us: the time of the chunk that ended the frame.
    bool on_sample(std::uint64_t host_time_us, const protocol::FrameEvent& event);
    // The same from parts. Returns false (and records nothing) for a message is_valid() rejects.
    bool on_message(std::uint64_t host_time_us, std::uint64_t stream_offset, std::uint16_t seq,
                    const protocol::Message& message);
    bool on_gpio(std::uint64_t time_us, std::uint32_t line, Edge edge, std::string_view chip = {});
    // An annotation stamped with the recorder's clock, or with an explicit time.
    bool mark(std::string_view text);
    bool mark(std::uint64_t time_us, std::string_view text);
    // The transport was reopened: the driver's decoder restarts at stream offset 0 (reset()).
    bool on_stream_restart(std::uint64_t time_us, std::string_view reason);

    // Writes buffered records and syncs them to the disk now.
    bool flush();
    // flush(), then closes the file. Idempotent; later appends return false.
    bool close();

    bool ok() const;
    std::string error() const;  // "" while ok
    const std::string& path() const { return path_; }
    const FileHeader& header() const { return header_; }
    std::uint64_t records_written() const;  // records appended (buffered or on disk)
    std::uint64_t syncs() const;            // fdatasync calls that succeeded

private:
    bool append(const RecordBody& body);
    bool write_buffer();
    bool sync();
    void fail(const char* what, int err);

    mutable std::mutex mutex_;
    std::string path_;
    FileHeader header_;
    RecorderOptions options_;
    Clock& clock_;
    detail::UniqueFd fd_;
    Bytes buffer_;
    bool closed_ = false;
    std::string error_;
    std::uint64_t rx_offset_ = 0;  // received bytes since the start or the last stream restart
    std::uint64_t tx_offset_ = 0;  // sent bytes, likewise
    std::uint64_t records_ = 0;
    std::uint64_t syncs_ = 0;
    std::uint64_t last_sync_us_ = 0;
    bool unsynced_ = false;        // records appended since the last sync
};

}  // namespace glint::recording
