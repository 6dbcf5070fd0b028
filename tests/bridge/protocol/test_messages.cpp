// Payload codec: round trip of every message type, byte layout spot checks, range validation.
#include <gtest/gtest.h>

#include <cmath>

#include "protocol_test_support.hpp"

namespace glint::protocol {
namespace {

using test::Bytes;

TEST(Messages, EveryTypeRoundTripsThroughPayloadCodec) {
    for (const Message& m : test::sample_messages()) {
        const Bytes payload = test::payload_of(m);
        EXPECT_EQ(payload.size(), payload_size(m.type)) << type_name(static_cast<std::uint8_t>(m.type));
        Message back;
        EXPECT_EQ(decode_payload(static_cast<std::uint8_t>(m.type), payload, back), PayloadStatus::Ok);
        EXPECT_TRUE(back == m) << type_name(static_cast<std::uint8_t>(m.type));
    }
}

TEST(Messages, EveryTypeRoundTripsThroughAFrame) {
    std::uint16_t seq = 100;
    for (const Message& m : test::sample_messages()) {
        const Bytes frame = test::encode(m, seq);
        ASSERT_FALSE(frame.empty());
        EXPECT_EQ(frame.back(), 0x00);
        EXPECT_EQ(std::count(frame.begin(), frame.end(), 0), 1);  // only the delimiter
        FrameDecoder decoder;
        const auto events = test::decode_stream(decoder, frame);
        ASSERT_EQ(events.size(), 1u);
        EXPECT_EQ(events[0].status, FrameStatus::Ok) << status_name(events[0].status);
        EXPECT_EQ(events[0].seq, seq);
        EXPECT_EQ(events[0].type, static_cast<std::uint8_t>(m.type));
        EXPECT_EQ(events[0].size, frame.size());
        EXPECT_FALSE(events[0].extended);
        EXPECT_TRUE(events[0].message == m) << type_name(static_cast<std::uint8_t>(m.type));
        ++seq;
    }
}

TEST(Messages, EveryKnownTypeHasANameAndAllOthersAreUnknown) {
    int known = 0;
    for (int t = 0; t < 256; ++t) {
        const auto type = static_cast<std::uint8_t>(t);
        if (is_known_type(type)) {
            ++known;
            EXPECT_STRNE(type_name(type), "unknown");
        } else {
            EXPECT_STREQ(type_name(type), "unknown");
        }
    }
    EXPECT_EQ(known, 11);
    EXPECT_EQ(test::sample_messages().size(), 11u);  // the samples cover every type
}

TEST(Messages, OrientationLayoutIsLittleEndianAtDocumentedOffsets) {
    const Orientation o{0x0102030405060708ull, kQ30One, 0, 0, -1};  // identity, z one LSB off
    const Bytes p = test::payload_of(o);
    ASSERT_EQ(p.size(), 24u);
    EXPECT_EQ(p[0], 0x08);  // timestamp, least significant byte first
    EXPECT_EQ(p[7], 0x01);
    EXPECT_EQ(p[8], 0x00);  // w = 2^30 = 0x40000000
    EXPECT_EQ(p[11], 0x40);
    for (int i = 20; i < 24; ++i) EXPECT_EQ(p[i], 0xFF) << i;  // z = -1
}

TEST(Messages, RawImuNegativeValuesAreTwosComplement) {
    RawImu r{};
    r.gyro_urad_s = {-1, 0, 0};
    const Bytes p = test::payload_of(r);
    EXPECT_EQ(p[8], 0xFF);
    EXPECT_EQ(p[11], 0xFF);
    Message back;
    ASSERT_EQ(decode_payload(static_cast<std::uint8_t>(MessageType::RawImu), p, back), PayloadStatus::Ok);
    EXPECT_EQ(back.raw_imu.gyro_urad_s[0], -1);
}

TEST(Messages, Q30ConversionIsExactAtOneAndRoundsToNearest) {
    EXPECT_EQ(to_q30(1.0), kQ30One);
    EXPECT_EQ(to_q30(-1.0), -kQ30One);
    EXPECT_EQ(to_q30(0.0), 0);
    EXPECT_EQ(to_q30(0.5 / kQ30One * 1.2), 1);   // 0.6 LSB rounds up
    EXPECT_EQ(to_q30(-0.5 / kQ30One * 1.2), -1);
    EXPECT_EQ(to_q30(5.0), INT32_MAX);           // saturates, never wraps
    EXPECT_EQ(to_q30(-5.0), INT32_MIN);
    EXPECT_EQ(to_q30(std::nan("")), INT32_MIN);
    for (double v : {0.9659258262890683, -0.25881904510252074, 1e-9}) {
        EXPECT_NEAR(from_q30(to_q30(v)), v, 0.5 / kQ30One);
    }
}

TEST(Messages, OutOfRangeFieldsAreRefusedOnEncodeAndReportedOnDecode) {
    FusionStatus bad_calib{1, FusionMode::Imu, 0, 4, 0, 0, {0, 0, 0}};  // level 4 > 3
    FusionStatus bad_mode{1, static_cast<FusionMode>(3), 0, 0, 0, 0, {0, 0, 0}};
    ButtonEvent bad_state{1, 0, static_cast<ButtonState>(2)};
    ConfigSet bad_bool{1, {ValueType::Bool, 2}};
    ConfigSet bad_value_type{1, {static_cast<ValueType>(9), 0}};
    ConfigAck bad_status{0, 1, static_cast<ConfigStatus>(4), ConfigValue::from_u32(0)};
    Orientation zero_quaternion{1, 0, 0, 0, 0};
    Orientation too_long{1, to_q30(1.2), 0, 0, 0};
    const std::vector<Message> bad = {bad_calib, bad_mode, bad_state, bad_bool, bad_value_type,
                                      bad_status, zero_quaternion, too_long};
    for (const Message& m : bad) {
        const auto name = type_name(static_cast<std::uint8_t>(m.type));
        EXPECT_FALSE(is_valid(m)) << name;
        Bytes out(kMaxFrameSize);
        EXPECT_EQ(encode_frame(m, 0, out).status, EncodeStatus::BadValue) << name;

        // Build the same bytes by hand (as a buggy sender would) and decode them.
        Bytes payload(payload_size(m.type));
        switch (m.type) {
            case MessageType::FusionStatus:
                payload[8] = static_cast<std::uint8_t>(m.fusion_status.mode);
                payload[10] = m.fusion_status.calib_gyro;
                break;
            case MessageType::ButtonEvent: payload[9] = static_cast<std::uint8_t>(m.button_event.state); break;
            case MessageType::ConfigSet:
                payload[2] = static_cast<std::uint8_t>(m.config_set.value.type);
                payload[3] = static_cast<std::uint8_t>(m.config_set.value.bits);
                break;
            case MessageType::ConfigAck: payload[4] = static_cast<std::uint8_t>(m.config_ack.status); break;
            case MessageType::Orientation: {
                const std::uint32_t w = static_cast<std::uint32_t>(m.orientation.w_q30);
                for (int i = 0; i < 4; ++i) payload[8 + i] = static_cast<std::uint8_t>(w >> (8 * i));
                break;
            }
            default: FAIL() << name;
        }
        const Bytes frame = test::encode_raw(kVersionMajor, static_cast<std::uint8_t>(m.type), 5, payload);
        FrameDecoder decoder;
        const auto events = test::decode_stream(decoder, frame);
        ASSERT_EQ(events.size(), 1u);
        EXPECT_EQ(events[0].status, FrameStatus::BadValue) << name;
        EXPECT_TRUE(events[0].header_valid);
        EXPECT_EQ(events[0].type, static_cast<std::uint8_t>(m.type));
        EXPECT_EQ(decoder.stats().bad_values, 1u);
    }
}

TEST(Messages, ConfigValueHelpersKeepTheBitPattern) {
    EXPECT_EQ(ConfigValue::from_f32(1.5f).as_f32(), 1.5f);
    EXPECT_EQ(ConfigValue::from_f32(1.0f).bits, 0x3F800000u);
    EXPECT_EQ(ConfigValue::from_i32(-7).as_i32(), -7);
    EXPECT_EQ(ConfigValue::from_i32(-1).bits, 0xFFFFFFFFu);
    EXPECT_TRUE(ConfigValue::from_bool(true).as_bool());
    EXPECT_EQ(ConfigValue::from_u32(200).as_u32(), 200u);
}

TEST(Messages, EncodeRefusesUnknownTypeAndSmallBuffers) {
    Message m = test::sample_orientation();
    m.type = static_cast<MessageType>(0x7E);
    Bytes out(kMaxFrameSize);
    EXPECT_EQ(encode_frame(m, 0, out).status, EncodeStatus::UnknownType);

    const Message ok = test::sample_orientation();
    const Bytes frame = test::encode(ok, 0);
    for (std::size_t cap = 0; cap < frame.size(); ++cap) {
        Bytes small(cap);
        EXPECT_EQ(encode_frame(ok, 0, small).status, EncodeStatus::BufferTooSmall) << cap;
    }
    Bytes exact(frame.size());
    EXPECT_EQ(encode_frame(ok, 0, exact).status, EncodeStatus::Ok);
    EXPECT_EQ(exact, frame);

    Bytes big_payload(kMaxPayloadSize + 1, 1);
    EXPECT_EQ(encode_raw_frame(1, 2, 0, big_payload, out).status, EncodeStatus::PayloadTooLarge);
}

TEST(Messages, FrameWriterNumbersFramesAndWraps) {
    FrameWriter writer(65534);
    Bytes out(kMaxFrameSize);
    std::vector<std::uint16_t> seqs;
    for (int i = 0; i < 3; ++i) {
        const EncodeResult r = writer.write(test::sample_orientation(), out);
        ASSERT_EQ(r.status, EncodeStatus::Ok);
        FrameDecoder d;
        const auto events = test::decode_stream(d, Bytes(out.begin(), out.begin() + static_cast<long>(r.size)));
        ASSERT_EQ(events.size(), 1u);
        seqs.push_back(events[0].seq);
    }
    EXPECT_EQ(seqs, (std::vector<std::uint16_t>{65534, 65535, 0}));
    Bytes tiny(3);
    EXPECT_EQ(writer.write(test::sample_orientation(), tiny).status, EncodeStatus::BufferTooSmall);
    EXPECT_EQ(writer.next_seq(), 1);  // a failed write does not use up a number
}

TEST(Messages, LargestV1FrameFitsMaxFrameSize) {
    std::size_t largest = 0;
    for (const Message& m : test::sample_messages()) largest = std::max(largest, test::encode(m, 0).size());
    EXPECT_LE(largest, kMaxFrameSize);
    // A maximal raw frame (246-byte payload of non-zero bytes) is exactly kMaxFrameSize.
    const Bytes frame = test::encode_raw(1, 0x7F, 0x0101, Bytes(kMaxPayloadSize, 0x5A));
    EXPECT_LE(frame.size(), kMaxFrameSize);
}

}  // namespace
}  // namespace glint::protocol
