// CRC-32C (Castagnoli) as used by the frame trailer; see PROTOCOL.md "Integrity check".
//
//   width 32, poly 0x1EDC6F41 (reflected 0x82F63B78), init 0xFFFFFFFF,
//   refin = refout = true, xorout 0xFFFFFFFF, check("123456789") = 0xE3069283.
#pragma once

#include <cstdint>
#include <span>

namespace glint::protocol {

inline constexpr std::uint32_t kCrc32cInit = 0xFFFFFFFFu;
inline constexpr std::uint32_t kCrc32cXorOut = 0xFFFFFFFFu;
inline constexpr std::uint32_t kCrc32cCheck = 0xE3069283u;  // CRC of the ASCII bytes "123456789"

// Advances a running CRC register (start with kCrc32cInit) over `data`. Lets a caller checksum
// a frame in pieces (header, then payload) without copying them together.
std::uint32_t crc32c_update(std::uint32_t reg, std::span<const std::uint8_t> data);

// Final CRC value of a running register.
inline std::uint32_t crc32c_finish(std::uint32_t reg) { return reg ^ kCrc32cXorOut; }

// CRC-32C of one buffer.
inline std::uint32_t crc32c(std::span<const std::uint8_t> data) {
    return crc32c_finish(crc32c_update(kCrc32cInit, data));
}

}  // namespace glint::protocol
