// One-line text forms of messages, records and decoder statistics, for the glint-recording tool
// and for verification reports. Units are spelled out (board µs, Q30 as decimals, µrad/s...).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "firmware_bridge/protocol/frame_decoder.hpp"
#include "firmware_bridge/protocol/messages.hpp"
#include "firmware_bridge/recording/format.hpp"

namespace glint::recording {

// "orientation board_t=1000000us q=(0.707107, 0, 0.707107, 0)"
std::string describe_message(const protocol::Message& message);
// "raw_bytes rx t=...us offset=... 37 bytes: 04 01 ..." (hex of at most `max_hex` bytes)
std::string describe_record(const RecordBody& body, std::size_t max_hex = 64);
// Text with control characters and non-ASCII bytes shown as \xNN, so one record is one line.
std::string printable(const std::string& text);
std::string hex_bytes(std::span<const std::uint8_t> bytes, std::size_t max_bytes);
// Multi-line "name value" table of the decoder statistics.
std::string describe_stats(const protocol::DecoderStats& stats);

}  // namespace glint::recording
