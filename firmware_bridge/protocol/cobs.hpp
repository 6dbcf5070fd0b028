// Consistent Overhead Byte Stuffing (Cheshire & Baker, 1999): removes every 0x00 from a frame
// body so that 0x00 can delimit frames on the wire. Overhead is 1 byte per started 254 bytes.
// These functions work on one frame body and never write the 0x00 delimiter themselves.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace glint::protocol {

// Largest COBS encoding of `size` input bytes (without the delimiter): one code byte per started
// run of 254 bytes, and a lone code byte for empty input.
constexpr std::size_t cobs_max_encoded_size(std::size_t size) {
    return size == 0 ? 1 : size + (size + 253) / 254;
}

struct CobsResult {
    bool ok = false;        // false: output buffer too small (encode) or malformed input (decode)
    std::size_t size = 0;   // bytes written to the output when ok
};

// Encodes `in` into `out` in the canonical form (no trailing 0x01 block after a final
// 254-byte run). Fails only when `out` is too small; `out` must not overlap `in`.
CobsResult cobs_encode(std::span<const std::uint8_t> in, std::span<std::uint8_t> out);

// Decodes one COBS block sequence (delimiter already removed). Fails when a code byte is 0,
// a code byte points past the end of `in`, a data byte is 0, or `out` is too small.
CobsResult cobs_decode(std::span<const std::uint8_t> in, std::span<std::uint8_t> out);

}  // namespace glint::protocol
