// COBS encoder and decoder, bounds-checked on every write (inputs may be arbitrary garbage).
#include "firmware_bridge/protocol/cobs.hpp"

namespace glint::protocol {

namespace {
constexpr std::uint8_t kMaxCode = 0xFF;  // a block of 254 data bytes with no implied zero
}

CobsResult cobs_encode(std::span<const std::uint8_t> in, std::span<std::uint8_t> out) {
    if (out.empty()) return {};
    std::size_t code_pos = 0;  // where the code byte of the open block goes
    std::size_t out_pos = 1;
    std::uint8_t code = 1;     // 1 + number of data bytes in the open block
    for (const std::uint8_t byte : in) {
        // Close a full block only when another byte follows: that keeps the encoding canonical
        // (254 non-zero bytes encode to 255 bytes, not 256).
        if (code == kMaxCode) {
            out[code_pos] = code;
            if (out_pos >= out.size()) return {};
            code_pos = out_pos++;
            code = 1;
        }
        if (byte == 0) {
            out[code_pos] = code;
            if (out_pos >= out.size()) return {};
            code_pos = out_pos++;
            code = 1;
        } else {
            if (out_pos >= out.size()) return {};
            out[out_pos++] = byte;
            ++code;
        }
    }
    out[code_pos] = code;
    return {true, out_pos};
}

CobsResult cobs_decode(std::span<const std::uint8_t> in, std::span<std::uint8_t> out) {
    std::size_t in_pos = 0;
    std::size_t out_pos = 0;
    while (in_pos < in.size()) {
        const std::uint8_t code = in[in_pos++];
        if (code == 0) return {};
        const std::size_t run = static_cast<std::size_t>(code) - 1;
        if (run > in.size() - in_pos || run > out.size() - out_pos) return {};
        for (std::size_t i = 0; i < run; ++i) {
            const std::uint8_t byte = in[in_pos++];
            if (byte == 0) return {};
            out[out_pos++] = byte;
        }
        // Every block but a full one implies a zero, except the zero that the delimiter replaces.
        if (code != kMaxCode && in_pos < in.size()) {
            if (out_pos >= out.size()) return {};
            out[out_pos++] = 0;
        }
    }
    return {true, out_pos};
}

}  // namespace glint::protocol
