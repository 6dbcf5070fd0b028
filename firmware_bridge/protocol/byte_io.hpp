// Little-endian field access for the wire format, byte by byte: independent of the host's
// endianness and alignment, so the same code is right on a Cortex-M and on the appliance.
#pragma once

#include <cstddef>
#include <cstdint>

namespace glint::protocol::byte_io {

inline void put_u8(std::uint8_t* p, std::uint8_t v) { p[0] = v; }

inline void put_u16(std::uint8_t* p, std::uint16_t v) {
    p[0] = static_cast<std::uint8_t>(v);
    p[1] = static_cast<std::uint8_t>(v >> 8);
}

inline void put_u32(std::uint8_t* p, std::uint32_t v) {
    for (std::size_t i = 0; i < 4; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

inline void put_u64(std::uint8_t* p, std::uint64_t v) {
    for (std::size_t i = 0; i < 8; ++i) p[i] = static_cast<std::uint8_t>(v >> (8 * i));
}

// Two's complement on the wire; the conversion to unsigned is well defined for every value.
inline void put_i32(std::uint8_t* p, std::int32_t v) { put_u32(p, static_cast<std::uint32_t>(v)); }

inline std::uint8_t get_u8(const std::uint8_t* p) { return p[0]; }

inline std::uint16_t get_u16(const std::uint8_t* p) {
    return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}

inline std::uint32_t get_u32(const std::uint8_t* p) {
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < 4; ++i) v |= static_cast<std::uint32_t>(p[i]) << (8 * i);
    return v;
}

inline std::uint64_t get_u64(const std::uint8_t* p) {
    std::uint64_t v = 0;
    for (std::size_t i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
    return v;
}

// C++20 defines unsigned-to-signed conversion as modular, so this is exact two's complement.
inline std::int32_t get_i32(const std::uint8_t* p) { return static_cast<std::int32_t>(get_u32(p)); }

}  // namespace glint::protocol::byte_io
