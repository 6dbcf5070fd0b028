// Incremental receiver of frames: fed byte chunks split anywhere, it finds frames between 0x00
// delimiters, checks COBS, length, CRC, version, type and payload, reports one FrameEvent per
// delimited frame (accepted or rejected) with the stream byte offset where the frame started,
// and keeps statistics. Garbage is discarded up to the next delimiter, so the decoder is back in
// step after at most one rejected frame. Fixed buffers, no heap, no exceptions.
//
// Feeding the same bytes in any chunking gives the same events and statistics, which is what a
// recorder/player relies on: record the raw bytes, replay them through a fresh FrameDecoder.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "firmware_bridge/protocol/frame.hpp"
#include "firmware_bridge/protocol/messages.hpp"

namespace glint::protocol {

enum class FrameStatus : std::uint8_t {
    Ok = 0,           // message decoded (event.message is valid)
    CobsError,        // the bytes between delimiters are not a valid COBS encoding
    TooShort,         // decoded body shorter than header + CRC (8 bytes)
    CrcError,         // CRC-32C mismatch: a damaged frame or garbage
    VersionMismatch,  // intact frame of another major version
    UnknownType,      // intact frame whose type this version does not define
    BadLength,        // intact frame whose payload is shorter than its type's layout
    BadValue,         // intact frame with a field out of range (e.g. calibration level 7)
    Oversize,         // more than kMaxEncodedBodySize bytes before a delimiter
    TruncatedAtEnd,   // finish(): the stream ended inside a frame
};
const char* status_name(FrameStatus status);

// Counts since construction or reset(). Every byte fed is in exactly one of: bytes_accepted,
// bytes_discarded, idle_delimiters, or the pending partial frame (FrameDecoder::pending_bytes).
struct DecoderStats {
    std::uint64_t bytes_in = 0;          // all bytes fed
    std::uint64_t bytes_accepted = 0;    // bytes of Ok frames, delimiters included
    std::uint64_t bytes_discarded = 0;   // bytes of rejected frames, delimiters included
    std::uint64_t idle_delimiters = 0;   // 0x00 with no frame before it (sender's flush bytes)
    std::uint64_t frames_ok = 0;
    std::uint64_t cobs_errors = 0;
    std::uint64_t too_short = 0;
    std::uint64_t crc_errors = 0;
    std::uint64_t version_mismatches = 0;
    std::uint64_t unknown_types = 0;
    std::uint64_t bad_lengths = 0;
    std::uint64_t bad_values = 0;
    std::uint64_t oversize_frames = 0;
    std::uint64_t truncated_at_end = 0;
    std::uint64_t extended_payloads = 0;  // Ok frames longer than this version's layout
    std::uint64_t lost_frames = 0;        // sum of sequence gaps (modulo 65536 each)
    std::uint64_t sender_restarts = 0;    // Hello with seq 0: sequence tracking restarted

    friend bool operator==(const DecoderStats&, const DecoderStats&) = default;
};

// One delimited frame, accepted or not.
struct FrameEvent {
    FrameStatus status = FrameStatus::Ok;
    std::uint64_t offset = 0;  // stream offset of the frame's first byte (bytes fed before it)
    std::uint32_t size = 0;    // bytes from offset through the delimiter (no delimiter: TruncatedAtEnd)
    // True when the CRC matched: version, type, seq and payload_size below are the sender's.
    bool header_valid = false;
    std::uint8_t version_major = 0;
    std::uint8_t type = 0;
    std::uint16_t seq = 0;
    std::uint16_t payload_size = 0;
    bool extended = false;         // Ok, but the payload was longer than this version knows
    std::uint16_t lost_before = 0; // frames missing (by sequence number) just before this one
    Message message;               // the decoded message; valid only when status == Ok
};

class FrameDecoder {
public:
    struct FeedResult {
        std::size_t consumed = 0;  // bytes of the input used, always > 0 for non-empty input
        bool has_event = false;    // an event was written
    };

    // Consumes input up to and including the first delimiter that ends a (non-empty) frame and
    // writes that frame's event; or consumes everything if no frame ends. Poll loop:
    //   while (!bytes.empty()) { auto r = d.feed(bytes, ev); bytes = bytes.subspan(r.consumed); ... }
    FeedResult feed(std::span<const std::uint8_t> input, FrameEvent& event);

    // Feeds a whole chunk and calls on_event(const FrameEvent&) for every frame in it.
    template <typename OnEvent>
    void feed_all(std::span<const std::uint8_t> input, OnEvent&& on_event) {
        while (!input.empty()) {
            const FeedResult r = feed(input, event_);
            input = input.subspan(r.consumed);
            if (r.has_event) on_event(static_cast<const FrameEvent&>(event_));
        }
    }

    // End of stream (file ended, port closed): reports a pending partial frame as TruncatedAtEnd
    // and discards it. Returns false when nothing was pending.
    bool finish(FrameEvent& event);

    // Forget the expected sequence number (e.g. after reopening the port): the next frame is
    // not compared with the previous one.
    void restart_sequence() { have_last_seq_ = false; }

    // Back to the state after construction: offsets, statistics and sequence tracking cleared.
    void reset();

    const DecoderStats& stats() const { return stats_; }
    std::uint64_t stream_offset() const { return stats_.bytes_in; }  // offset of the next byte
    std::uint64_t pending_bytes() const { return pending_; }         // bytes of the open frame

private:
    void complete_frame(FrameEvent& event);
    void decode_body(std::span<const std::uint8_t> encoded, FrameEvent& event);
    void track_sequence(FrameEvent& event);

    std::array<std::uint8_t, kMaxEncodedBodySize> encoded_{};  // open frame, COBS form
    std::array<std::uint8_t, kMaxBodySize> body_{};            // decoded body of a closed frame
    std::size_t encoded_size_ = 0;
    std::uint64_t pending_ = 0;       // bytes of the open frame (may exceed the buffer: oversize)
    std::uint64_t frame_start_ = 0;   // stream offset of the open frame's first byte
    bool have_last_seq_ = false;
    std::uint16_t last_seq_ = 0;
    DecoderStats stats_{};
    FrameEvent event_{};              // storage for feed_all's events (no heap, no large stack)
};

}  // namespace glint::protocol
