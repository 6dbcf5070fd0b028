// Frame encoder: body assembled in a stack buffer, CRC appended, COBS-encoded into the caller's span.
#include "firmware_bridge/protocol/frame.hpp"

#include <array>
#include <cstring>

#include "firmware_bridge/protocol/byte_io.hpp"
#include "firmware_bridge/protocol/crc32c.hpp"

namespace glint::protocol {

namespace {

// Adds header and CRC around the payload already at body[kHeaderSize ..) and COBS-encodes it.
EncodeResult finish_frame(std::span<std::uint8_t, kMaxBodySize> body, std::uint8_t version_major,
                          std::uint8_t type, std::uint16_t seq, std::size_t payload_size,
                          std::span<std::uint8_t> out) {
    byte_io::put_u8(body.data() + 0, version_major);
    byte_io::put_u8(body.data() + 1, type);
    byte_io::put_u16(body.data() + 2, seq);
    const std::size_t crc_offset = kHeaderSize + payload_size;
    byte_io::put_u32(body.data() + crc_offset, crc32c(body.first(crc_offset)));
    const std::size_t body_size = crc_offset + kCrcSize;

    if (out.empty()) return {EncodeStatus::BufferTooSmall, 0};
    const CobsResult cobs = cobs_encode(body.first(body_size), out.first(out.size() - 1));
    if (!cobs.ok) return {EncodeStatus::BufferTooSmall, 0};
    out[cobs.size] = kFrameDelimiter;
    return {EncodeStatus::Ok, cobs.size + 1};
}

}  // namespace

const char* status_name(EncodeStatus status) {
    switch (status) {
        case EncodeStatus::Ok: return "ok";
        case EncodeStatus::BufferTooSmall: return "output buffer too small";
        case EncodeStatus::UnknownType: return "unknown message type";
        case EncodeStatus::BadValue: return "field out of range";
        case EncodeStatus::PayloadTooLarge: return "payload too large";
    }
    return "invalid status";
}

EncodeResult encode_frame(const Message& message, std::uint16_t seq, std::span<std::uint8_t> out) {
    std::array<std::uint8_t, kMaxBodySize> body{};
    const PayloadResult payload =
        encode_payload(message, std::span<std::uint8_t>(body).subspan(kHeaderSize, kMaxPayloadSize));
    switch (payload.status) {
        case PayloadStatus::Ok: break;
        case PayloadStatus::UnknownType: return {EncodeStatus::UnknownType, 0};
        case PayloadStatus::BadValue: return {EncodeStatus::BadValue, 0};
        // Cannot happen (every v1 payload fits kMaxPayloadSize); reported rather than assumed.
        case PayloadStatus::BadLength:
        case PayloadStatus::BufferTooSmall: return {EncodeStatus::PayloadTooLarge, 0};
    }
    return finish_frame(body, kVersionMajor, static_cast<std::uint8_t>(message.type), seq,
                        payload.size, out);
}

EncodeResult encode_raw_frame(std::uint8_t version_major, std::uint8_t type, std::uint16_t seq,
                              std::span<const std::uint8_t> payload, std::span<std::uint8_t> out) {
    if (payload.size() > kMaxPayloadSize) return {EncodeStatus::PayloadTooLarge, 0};
    std::array<std::uint8_t, kMaxBodySize> body{};
    if (!payload.empty()) std::memcpy(body.data() + kHeaderSize, payload.data(), payload.size());
    return finish_frame(body, version_major, type, seq, payload.size(), out);
}

EncodeResult FrameWriter::write(const Message& message, std::span<std::uint8_t> out) {
    const EncodeResult result = encode_frame(message, next_seq_, out);
    if (result.status == EncodeStatus::Ok) ++next_seq_;
    return result;
}

}  // namespace glint::protocol
