// Frames on the wire: COBS( header | payload | CRC-32C ) followed by one 0x00 delimiter.
//
//   header  = version_major u8 | type u8 | seq u16 LE      (4 bytes)
//   trailer = CRC-32C u32 LE over header and payload         (4 bytes)
//
// See PROTOCOL.md "Framing". Writing a frame needs no state but the sequence number, which
// FrameWriter keeps for a sender.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "firmware_bridge/protocol/cobs.hpp"
#include "firmware_bridge/protocol/messages.hpp"

namespace glint::protocol {

inline constexpr std::uint8_t kFrameDelimiter = 0x00;
inline constexpr std::size_t kHeaderSize = 4;
inline constexpr std::size_t kCrcSize = 4;
// Smallest body: header and CRC around an empty payload.
inline constexpr std::size_t kMinBodySize = kHeaderSize + kCrcSize;
// Largest body; chosen so that COBS adds exactly one byte to it.
inline constexpr std::size_t kMaxBodySize = kHeaderSize + kMaxPayloadSize + kCrcSize;
// Largest COBS-encoded body (the bytes between two delimiters).
inline constexpr std::size_t kMaxEncodedBodySize = cobs_max_encoded_size(kMaxBodySize);
// Largest frame on the wire, delimiter included. A buffer of this size holds any frame.
inline constexpr std::size_t kMaxFrameSize = kMaxEncodedBodySize + 1;

static_assert(kMaxBodySize == 254 && kMaxEncodedBodySize == 255 && kMaxFrameSize == 256);

enum class EncodeStatus : std::uint8_t {
    Ok = 0,
    BufferTooSmall,  // the output span cannot hold the frame (use kMaxFrameSize)
    UnknownType,     // message type not defined by this version
    BadValue,        // a field is out of range (see is_valid)
    PayloadTooLarge, // encode_raw_frame only: payload longer than kMaxPayloadSize
};
const char* status_name(EncodeStatus status);

struct EncodeResult {
    EncodeStatus status = EncodeStatus::Ok;
    std::size_t size = 0;  // bytes written, delimiter included, when Ok
};

// Writes `message` as one complete frame (ending with the 0x00 delimiter) into `out`.
EncodeResult encode_frame(const Message& message, std::uint16_t seq, std::span<std::uint8_t> out);

// Writes a frame with any version, type byte and payload bytes. For tests, tools and senders of
// payloads this version does not know (e.g. a newer minor's longer payload).
EncodeResult encode_raw_frame(std::uint8_t version_major, std::uint8_t type, std::uint16_t seq,
                              std::span<const std::uint8_t> payload, std::span<std::uint8_t> out);

// The sending side of one link: numbers frames 0, 1, 2, ... (wrapping at 65536). A board starts
// a FrameWriter at 0 after every reset and sends Hello first (PROTOCOL.md "Sequence numbers").
class FrameWriter {
public:
    explicit FrameWriter(std::uint16_t first_seq = 0) : next_seq_(first_seq) {}

    // Encodes with the next sequence number; the number advances only when the frame was written.
    EncodeResult write(const Message& message, std::span<std::uint8_t> out);

    std::uint16_t next_seq() const { return next_seq_; }

private:
    std::uint16_t next_seq_;
};

}  // namespace glint::protocol
