// Table-driven CRC-32C, one byte per step. The 1 KiB table is built at compile time so it
// lives in flash on the microcontroller and costs no start-up time.
#include "firmware_bridge/protocol/crc32c.hpp"

#include <array>
#include <cstddef>

namespace glint::protocol {
namespace {

constexpr std::uint32_t kReflectedPoly = 0x82F63B78u;  // 0x1EDC6F41 with its bits reversed

constexpr std::array<std::uint32_t, 256> make_table() {
    std::array<std::uint32_t, 256> table{};
    for (std::uint32_t byte = 0; byte < 256; ++byte) {
        std::uint32_t reg = byte;
        for (int bit = 0; bit < 8; ++bit) reg = (reg & 1u) ? (reg >> 1) ^ kReflectedPoly : reg >> 1;
        table[byte] = reg;
    }
    return table;
}

constexpr std::array<std::uint32_t, 256> kTable = make_table();

}  // namespace

std::uint32_t crc32c_update(std::uint32_t reg, std::span<const std::uint8_t> data) {
    for (const std::uint8_t byte : data) reg = (reg >> 8) ^ kTable[(reg ^ byte) & 0xFFu];
    return reg;
}

}  // namespace glint::protocol
