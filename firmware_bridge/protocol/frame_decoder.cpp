// FrameDecoder: byte-at-a-time state machine with one fixed buffer for the open frame.
#include "firmware_bridge/protocol/frame_decoder.hpp"

#include "firmware_bridge/protocol/byte_io.hpp"
#include "firmware_bridge/protocol/cobs.hpp"
#include "firmware_bridge/protocol/crc32c.hpp"

namespace glint::protocol {

const char* status_name(FrameStatus status) {
    switch (status) {
        case FrameStatus::Ok: return "ok";
        case FrameStatus::CobsError: return "COBS error";
        case FrameStatus::TooShort: return "frame too short";
        case FrameStatus::CrcError: return "CRC mismatch";
        case FrameStatus::VersionMismatch: return "protocol major version mismatch";
        case FrameStatus::UnknownType: return "unknown message type";
        case FrameStatus::BadLength: return "payload too short for its type";
        case FrameStatus::BadValue: return "field out of range";
        case FrameStatus::Oversize: return "frame too long";
        case FrameStatus::TruncatedAtEnd: return "stream ended inside a frame";
    }
    return "invalid status";
}

FrameDecoder::FeedResult FrameDecoder::feed(std::span<const std::uint8_t> input, FrameEvent& event) {
    for (std::size_t i = 0; i < input.size(); ++i) {
        const std::uint8_t byte = input[i];
        ++stats_.bytes_in;
        if (byte != kFrameDelimiter) {
            if (pending_ == 0) frame_start_ = stats_.bytes_in - 1;
            // Past the buffer the frame is oversize anyway; only its length is still counted.
            if (encoded_size_ < encoded_.size()) encoded_[encoded_size_++] = byte;
            ++pending_;
            continue;
        }
        if (pending_ == 0) {
            ++stats_.idle_delimiters;
            continue;
        }
        ++pending_;  // the delimiter belongs to the frame it ends
        complete_frame(event);
        return {i + 1, true};
    }
    return {input.size(), false};
}

bool FrameDecoder::finish(FrameEvent& event) {
    if (pending_ == 0) return false;
    event = FrameEvent{};
    event.status = FrameStatus::TruncatedAtEnd;
    event.offset = frame_start_;
    event.size = static_cast<std::uint32_t>(pending_);
    ++stats_.truncated_at_end;
    stats_.bytes_discarded += pending_;
    pending_ = 0;
    encoded_size_ = 0;
    return true;
}

void FrameDecoder::reset() {
    encoded_size_ = 0;
    pending_ = 0;
    frame_start_ = 0;
    have_last_seq_ = false;
    last_seq_ = 0;
    stats_ = DecoderStats{};
}

void FrameDecoder::complete_frame(FrameEvent& event) {
    event = FrameEvent{};
    event.offset = frame_start_;
    // pending_ <= 2^32 in any real stream; saturate rather than wrap for absurd garbage runs.
    event.size = pending_ > UINT32_MAX ? UINT32_MAX : static_cast<std::uint32_t>(pending_);
    const bool oversize = pending_ - 1 > encoded_.size();
    const std::uint64_t frame_bytes = pending_;
    const std::size_t encoded_size = encoded_size_;
    pending_ = 0;
    encoded_size_ = 0;

    if (oversize) {
        event.status = FrameStatus::Oversize;
    } else {
        decode_body(std::span<const std::uint8_t>(encoded_).first(encoded_size), event);
    }

    switch (event.status) {
        case FrameStatus::Ok: ++stats_.frames_ok; break;
        case FrameStatus::CobsError: ++stats_.cobs_errors; break;
        case FrameStatus::TooShort: ++stats_.too_short; break;
        case FrameStatus::CrcError: ++stats_.crc_errors; break;
        case FrameStatus::VersionMismatch: ++stats_.version_mismatches; break;
        case FrameStatus::UnknownType: ++stats_.unknown_types; break;
        case FrameStatus::BadLength: ++stats_.bad_lengths; break;
        case FrameStatus::BadValue: ++stats_.bad_values; break;
        case FrameStatus::Oversize: ++stats_.oversize_frames; break;
        case FrameStatus::TruncatedAtEnd: ++stats_.truncated_at_end; break;
    }
    if (event.status == FrameStatus::Ok) {
        stats_.bytes_accepted += frame_bytes;
        if (event.extended) ++stats_.extended_payloads;
    } else {
        stats_.bytes_discarded += frame_bytes;
    }
}

void FrameDecoder::decode_body(std::span<const std::uint8_t> encoded, FrameEvent& event) {
    const CobsResult cobs = cobs_decode(encoded, body_);
    if (!cobs.ok) {
        event.status = FrameStatus::CobsError;
        return;
    }
    if (cobs.size < kMinBodySize) {
        event.status = FrameStatus::TooShort;
        return;
    }
    const std::span<const std::uint8_t> body = std::span<const std::uint8_t>(body_).first(cobs.size);
    const std::size_t crc_offset = cobs.size - kCrcSize;
    if (crc32c(body.first(crc_offset)) != byte_io::get_u32(body.data() + crc_offset)) {
        event.status = FrameStatus::CrcError;
        return;
    }

    // From here on the header is the sender's own (CRC-32C: see PROTOCOL.md for the residual risk).
    event.header_valid = true;
    event.version_major = byte_io::get_u8(body.data() + 0);
    event.type = byte_io::get_u8(body.data() + 1);
    event.seq = byte_io::get_u16(body.data() + 2);
    event.payload_size = static_cast<std::uint16_t>(crc_offset - kHeaderSize);
    if (event.version_major != kVersionMajor) {
        // Another major version may number its frames differently: leave sequence tracking alone.
        event.status = FrameStatus::VersionMismatch;
        return;
    }

    const std::span<const std::uint8_t> payload = body.subspan(kHeaderSize, event.payload_size);
    switch (decode_payload(event.type, payload, event.message)) {
        case PayloadStatus::Ok:
            event.status = FrameStatus::Ok;
            event.extended = payload.size() > payload_size(static_cast<MessageType>(event.type));
            break;
        case PayloadStatus::UnknownType: event.status = FrameStatus::UnknownType; break;
        case PayloadStatus::BadLength: event.status = FrameStatus::BadLength; break;
        case PayloadStatus::BadValue:
        case PayloadStatus::BufferTooSmall: event.status = FrameStatus::BadValue; break;
    }
    // An intact frame of this version, whatever its content, proves its sequence number.
    track_sequence(event);
}

void FrameDecoder::track_sequence(FrameEvent& event) {
    // A board restarts its numbering at 0 with a Hello after every reset: not a gap.
    const bool restart = event.status == FrameStatus::Ok && event.message.type == MessageType::Hello &&
                         event.seq == 0;
    if (restart) {
        if (have_last_seq_) ++stats_.sender_restarts;
    } else if (have_last_seq_) {
        // Unsigned 16-bit arithmetic makes the gap right across the 65535 -> 0 wrap.
        const auto gap = static_cast<std::uint16_t>(event.seq - static_cast<std::uint16_t>(last_seq_ + 1));
        event.lost_before = gap;
        stats_.lost_frames += gap;
    }
    have_last_seq_ = true;
    last_seq_ = event.seq;
}

}  // namespace glint::protocol
