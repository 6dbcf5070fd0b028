// Player: replays a recording's received raw bytes through the real protocol FrameDecoder and
// reports every frame event with the recorded receive time, plus the other records (markers,
// GPIO edges, decoded messages) in file order.
//
// Pacing comes from the Clock: each record is delivered when clock.now_us() reaches
// start + (record time - first record time), where start is the clock's time when play()
// began. With a SteadyClock that is recorded speed with real sleeps; with a VirtualClock the
// sleeps are instantaneous, so the replay runs as fast as possible and the virtual time seen by
// the sink equals the recorded timeline. The output depends only on the file's bytes: two
// replays give identical events (the decoder is deterministic and chunk-independent).
//
// Sent bytes (Direction::Sent) are not decoded; they reach the sink as records only.
#pragma once

#include <cstdint>

#include "firmware_bridge/protocol/frame_decoder.hpp"
#include "firmware_bridge/recording/clock.hpp"
#include "firmware_bridge/recording/reader.hpp"

namespace glint::recording {

// Receives the replay. Every method has an empty default.
class PlaybackSink {
public:
    virtual ~PlaybackSink() = default;
    // A frame the decoder delimited (any status), stamped with the receive time of the raw chunk
    // in which it ended (appliance monotonic µs). event.offset counts from the file's first raw
    // received byte, or from the last stream restart.
    virtual void on_frame(std::uint64_t host_time_us, const protocol::FrameEvent& event) {
        (void)host_time_us;
        (void)event;
    }
    // Every intact record, in file order, after its bytes (if any) were fed to the decoder.
    virtual void on_record(const Record& record) { (void)record; }
    // Damage in the file (from the reader) and stream gaps (from the player), when found.
    virtual void on_issue(const ReadIssue& issue) { (void)issue; }
};

struct PlaybackResult {
    protocol::DecoderStats stats;       // summed over all stream segments
    std::uint64_t records = 0;          // intact records read
    std::uint64_t issues = 0;           // issues reported to the sink
    std::uint64_t stream_restarts = 0;  // StreamRestart records (decoder reset each time)
    std::uint64_t first_time_us = 0;    // recorded time of the first timed record
    std::uint64_t last_time_us = 0;     // ... and of the last
};

// Adds every counter of `part` to `total`.
void accumulate(protocol::DecoderStats& total, const protocol::DecoderStats& part);

class Player {
public:
    Player(RecordingReader& reader, Clock& clock) : reader_(reader), clock_(clock) {}

    // Replays the whole file from its first record (rewinds the reader first).
    PlaybackResult play(PlaybackSink& sink);

private:
    RecordingReader& reader_;
    Clock& clock_;
};

}  // namespace glint::recording
