// Shared helpers of the protocol tests: one sample message of every type, frame encoding into
// byte vectors, and decoding a whole byte stream in chunks of a given size.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "firmware_bridge/protocol/frame.hpp"
#include "firmware_bridge/protocol/frame_decoder.hpp"
#include "firmware_bridge/protocol/messages.hpp"

namespace glint::protocol::test {

using Bytes = std::vector<std::uint8_t>;

// A 30 degree rotation about +Y (sensor turned left): w = cos 15deg, y = sin 15deg.
inline Orientation sample_orientation(std::uint64_t t_us = 1'234'567) {
    return {t_us, to_q30(0.9659258262890683), 0, to_q30(0.25881904510252074), 0};
}

// One message of every type, with distinct non-trivial field values.
inline std::vector<Message> sample_messages() {
    return {
        Hello{kVersionMajor, kVersionMinor, 2, 3, 0x0104, 0xC0FFEE01u,
              capability::kGyro | capability::kAccel | capability::kMag | capability::kOnBoardFusion |
                  capability::kRawImu | capability::kButtons,
              3},
        sample_orientation(),
        RawImu{5'000'001, {-1745, 3490, 0}, {12'000, -9'806'650, 250'000}, {22'500, -4'100, 41'000},
               raw_valid::kGyro | raw_valid::kAccel | raw_valid::kMag},
        FusionStatus{7'000'000, FusionMode::Ndof, 3, 3, 2, 1, {-120, 45, 7}},
        ButtonEvent{9'000'123, 2, ButtonState::Pressed},
        Heartbeat{10'000'000, 10, 2'001, 1, 5, 0},
        ErrorReport{11'000'000, static_cast<std::uint16_t>(ErrorCode::SensorReadFailed), capability::kMag},
        ConfigAck{17, static_cast<std::uint16_t>(ConfigKey::OrientationRateHz), ConfigStatus::Ok,
                  ConfigValue::from_u32(200)},
        HelloRequest{},
        ConfigGet{static_cast<std::uint16_t>(ConfigKey::BoardId)},
        ConfigSet{static_cast<std::uint16_t>(ConfigKey::MagEnabled), ConfigValue::from_bool(false)},
    };
}

inline Bytes encode(const Message& m, std::uint16_t seq) {
    Bytes out(kMaxFrameSize);
    const EncodeResult r = encode_frame(m, seq, out);
    EXPECT_EQ(r.status, EncodeStatus::Ok) << type_name(static_cast<std::uint8_t>(m.type));
    out.resize(r.size);
    return out;
}

inline Bytes encode_raw(std::uint8_t version, std::uint8_t type, std::uint16_t seq, const Bytes& payload) {
    Bytes out(kMaxFrameSize);
    const EncodeResult r = encode_raw_frame(version, type, seq, payload, out);
    EXPECT_EQ(r.status, EncodeStatus::Ok);
    out.resize(r.size);
    return out;
}

inline Bytes payload_of(const Message& m) {
    Bytes out(kMaxPayloadSize);
    const PayloadResult r = encode_payload(m, out);
    EXPECT_EQ(r.status, PayloadStatus::Ok);
    out.resize(r.size);
    return out;
}

inline void append(Bytes& stream, const Bytes& more) { stream.insert(stream.end(), more.begin(), more.end()); }

// Feeds `stream` in chunks of `chunk` bytes (the last may be shorter), then calls finish().
inline std::vector<FrameEvent> decode_stream(FrameDecoder& decoder, const Bytes& stream,
                                             std::size_t chunk = 4096, bool finish = true) {
    std::vector<FrameEvent> events;
    std::span<const std::uint8_t> rest(stream);
    while (!rest.empty()) {
        const std::size_t n = std::min(chunk, rest.size());
        decoder.feed_all(rest.first(n), [&](const FrameEvent& e) { events.push_back(e); });
        rest = rest.subspan(n);
    }
    FrameEvent tail;
    if (finish && decoder.finish(tail)) events.push_back(tail);
    return events;
}

inline std::string hex(std::span<const std::uint8_t> bytes) {
    static const char* digits = "0123456789abcdef";
    std::string s;
    for (std::size_t i = 0; i < bytes.size(); ++i) {
        if (i) s += ' ';
        s += digits[bytes[i] >> 4];
        s += digits[bytes[i] & 15];
    }
    return s;
}

// Every byte fed is accepted, discarded, an idle delimiter, or pending.
inline void expect_bytes_accounted(const FrameDecoder& d) {
    const DecoderStats& s = d.stats();
    EXPECT_EQ(s.bytes_in, s.bytes_accepted + s.bytes_discarded + s.idle_delimiters + d.pending_bytes());
}

}  // namespace glint::protocol::test
