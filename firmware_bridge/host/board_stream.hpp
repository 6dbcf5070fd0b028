// The one decode path for a sensor board's byte stream, live (serial) or replayed (a
// recording): bytes with their receive time -> the real FrameDecoder -> orientations mapped
// from board time to appliance time (board_clock.hpp) -> OrientationSource::publish, plus the
// decoder's counters for the health figures and the board's other messages for whoever listens.
// Optionally records the stream exactly as firmware_bridge/recording/FORMAT.md §7 asks.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "firmware_bridge/host/board_clock.hpp"
#include "firmware_bridge/host/orientation_history.hpp"
#include "firmware_bridge/host/orientation_source.hpp"
#include "firmware_bridge/protocol/frame_decoder.hpp"
#include "firmware_bridge/recording/recorder.hpp"

namespace glint::host {

// The board's latest status messages, for health displays.
struct BoardStatus {
    std::optional<protocol::Hello> hello;
    std::optional<protocol::FusionStatus> fusion;
    std::optional<protocol::Heartbeat> heartbeat;
    std::optional<protocol::ErrorReport> last_error;
};

class BoardStream {
public:
    using SampleSink = std::function<void(const OrientationSample&)>;
    using MessageSink = std::function<void(std::int64_t host_ns, const protocol::Message&)>;

    explicit BoardStream(SampleSink on_sample, BoardClockOptions clock_options = {});

    // Every chunk as read() returned it, stamped with the appliance time of the read.
    void feed(std::int64_t host_ns, std::span<const std::uint8_t> bytes);
    // The transport was reopened: the decoder starts over at stream offset 0 and forgets the
    // sequence, and the clock estimate starts over (it may be another board).
    void restart(std::int64_t host_ns, const char* reason);

    void set_message_sink(MessageSink sink) { on_message_ = std::move(sink); }
    void set_recorder(recording::Recorder* recorder) { recorder_ = recorder; }

    // Counters summed over every restart.
    std::uint64_t crc_errors() const;
    std::uint64_t frame_errors() const;  // every other rejected frame
    std::uint64_t lost_frames() const;
    std::uint64_t frames_ok() const;
    // Orientations dropped because their mapped time was not after the previous sample's: a
    // chunk carried more board time than host time passed since the last one (a backlog, e.g.
    // right after opening the port), so the improved estimate places it in the past. Not
    // published: a time that is known to be wrong is worse than no sample.
    std::uint64_t untimed_samples() const { return untimed_; }
    const BoardClock& clock() const { return clock_; }
    // Copies the stream's counters (crc, frame errors, lost, untimed, drift) into `health`.
    void copy_counters(LinkHealth& health) const;
    const BoardStatus& status() const { return status_; }

private:
    protocol::DecoderStats total() const;

    SampleSink on_sample_;
    MessageSink on_message_;
    recording::Recorder* recorder_ = nullptr;
    protocol::FrameDecoder decoder_;
    protocol::DecoderStats before_restarts_{};
    BoardClock clock_;
    BoardStatus status_;
    std::optional<std::int64_t> last_published_ns_;
    std::vector<OrientationSample> chunk_samples_;  // orientations of the chunk being fed
    std::uint64_t untimed_ = 0;
};

}  // namespace glint::host
