// Byte layouts of every message type, written BY HAND from the tables of PROTOCOL.md section 3
// (not produced by the encoder), so a field moved, swapped, resized or byte-swapped in
// messages.cpp describe() fails here even when encode and decode stay consistent with each
// other (which the round-trip tests in test_messages.cpp cannot see). Field values are chosen so
// that every byte of a payload differs from its neighbours: any two fields swapped change bytes.
// The second half checks frames typed in from PROTOCOL.md's worked examples (section 4).
#include <gtest/gtest.h>

#include "protocol_test_support.hpp"

namespace glint::protocol {
namespace {

using test::Bytes;

// encode_payload(m) must be exactly `expected`, and decode_payload(expected) must give m back.
void expect_layout(const Message& m, const Bytes& expected) {
    const auto type = static_cast<std::uint8_t>(m.type);
    SCOPED_TRACE(type_name(type));
    ASSERT_EQ(expected.size(), payload_size(m.type)) << "the hand-written payload has the documented size";
    Bytes out(kMaxPayloadSize, 0xEE);
    const PayloadResult r = encode_payload(m, out);
    ASSERT_EQ(r.status, PayloadStatus::Ok) << status_name(r.status);
    out.resize(r.size);
    EXPECT_EQ(test::hex(out), test::hex(expected));
    Message back;
    ASSERT_EQ(decode_payload(type, expected, back), PayloadStatus::Ok);
    EXPECT_TRUE(back == m) << "decoding the documented bytes does not give the fields back";
}

// 3.3: major u8 | minor u8 | fw major u8 | fw minor u8 | fw patch u16 | board_id u32 | caps u32 | buttons u8
TEST(PayloadLayout, Hello) {
    const Hello h{1, 0, 0x02, 0x03, 0x0504, 0x0A090807u, 0x0000001Bu, 0x0C};
    expect_layout(h, {0x01, 0x00, 0x02, 0x03, 0x04, 0x05, 0x07, 0x08, 0x09, 0x0A, 0x1B, 0x00, 0x00, 0x00, 0x0C});
}

// 3.4: timestamp u64 | w i32 | x i32 | y i32 | z i32 (|q| = 1.02, inside the accepted band)
TEST(PayloadLayout, Orientation) {
    const Orientation o{0x0807060504030201ull, 0x3A000000, 0x0D0C0B0A, 0x11100F0E, 0x15141312};
    expect_layout(o, {0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08,   // timestamp_us
                      0x00, 0x00, 0x00, 0x3A,                           // w
                      0x0A, 0x0B, 0x0C, 0x0D,                           // x
                      0x0E, 0x0F, 0x10, 0x11,                           // y
                      0x12, 0x13, 0x14, 0x15});                         // z
}

// 3.5: timestamp u64 | gyro i32 x3 @8 | accel i32 x3 @20 | mag i32 x3 @32 | valid u8 @44
TEST(PayloadLayout, RawImu) {
    const RawImu r{0x0807060504030201ull,
                   {0x0C0B0A09, 0x100F0E0D, 0x14131211},
                   {0x18171615, 0x1C1B1A19, 0x201F1E1D},
                   {0x24232221, 0x28272625, -2},
                   raw_valid::kGyro | raw_valid::kMag};
    Bytes expected;
    for (std::uint8_t b = 0x01; b <= 0x28; ++b) expected.push_back(b);  // timestamp .. mag y
    expected.insert(expected.end(), {0xFE, 0xFF, 0xFF, 0xFF});     // mag z = -2
    expected.push_back(0x05);                                           // valid: gyro | mag
    expect_layout(r, expected);
}

// 3.6: timestamp u64 | mode u8 @8 | calib sys, gyro, accel, mag u8 @9..12 | gyro_bias i32 x3 @13
TEST(PayloadLayout, FusionStatus) {
    const FusionStatus f{0x1122334455667788ull, FusionMode::Ndof, 3, 2, 1, 0, {-2, 0x01020304, 0x7FFFFFFE}};
    expect_layout(f, {0x88, 0x77, 0x66, 0x55, 0x44, 0x33, 0x22, 0x11,  // timestamp_us
                      0x02,                                            // mode Ndof
                      0x03, 0x02, 0x01, 0x00,                          // calib system, gyro, accel, mag
                      0xFE, 0xFF, 0xFF, 0xFF,                          // bias x = -2
                      0x04, 0x03, 0x02, 0x01,                          // bias y
                      0xFE, 0xFF, 0xFF, 0x7F});                        // bias z
}

// 3.7: timestamp u64 | button_id u8 @8 | state u8 @9
TEST(PayloadLayout, ButtonEvent) {
    const ButtonEvent b{0x00000000BEEF01ull, 7, ButtonState::Pressed};
    expect_layout(b, {0x01, 0xEF, 0xBE, 0x00, 0x00, 0x00, 0x00, 0x00, 0x07, 0x01});
}

// 3.8: timestamp u64 | uptime_s | frames_sent | frames_dropped | rx_frames_ok | rx_frames_bad (u32)
TEST(PayloadLayout, Heartbeat) {
    const Heartbeat h{0x0807060504030201ull, 0x0C0B0A09u, 0x100F0E0Du, 0x14131211u, 0x18171615u, 0x1C1B1A19u};
    Bytes expected;
    for (std::uint8_t b = 0x01; b <= 0x1C; ++b) expected.push_back(b);
    expect_layout(h, expected);
}

// 3.9: timestamp u64 | code u16 @8 | detail u32 @10. An unknown code is passed on unchanged.
TEST(PayloadLayout, ErrorReport) {
    const ErrorReport e{0x0807060504030201ull, 0x0A09, 0x0E0D0C0Bu};
    Bytes expected;
    for (std::uint8_t b = 0x01; b <= 0x0E; ++b) expected.push_back(b);
    expect_layout(e, expected);
}

// 3.10 ConfigAck: request_seq u16 | key u16 | status u8 @4 | value_type u8 @5 | bits u32 @6
TEST(PayloadLayout, ConfigAck) {
    const ConfigAck a{0x0201, 0x0403, ConfigStatus::ReadOnly, ConfigValue::from_f32(1.5f)};
    expect_layout(a, {0x01, 0x02, 0x03, 0x04, 0x03, 0x02, 0x00, 0x00, 0xC0, 0x3F});  // 1.5f = 0x3FC00000
}

// 3.11: empty payload.
TEST(PayloadLayout, HelloRequest) { expect_layout(HelloRequest{}, {}); }

// 3.10 ConfigGet: key u16
TEST(PayloadLayout, ConfigGet) { expect_layout(ConfigGet{0x0102}, {0x02, 0x01}); }

// 3.10 ConfigSet: key u16 | value_type u8 @2 | bits u32 @3
TEST(PayloadLayout, ConfigSet) {
    expect_layout(ConfigSet{0x0A0B, ConfigValue::from_i32(-2)}, {0x0B, 0x0A, 0x01, 0xFE, 0xFF, 0xFF, 0xFF});
    expect_layout(ConfigSet{0x0006, ConfigValue::from_bool(true)}, {0x06, 0x00, 0x03, 0x01, 0x00, 0x00, 0x00});
}

// Frames typed in from PROTOCOL.md section 4 (a copy, on purpose: test_doc_examples.cpp compares
// the document with the encoder by parsing it, which would pass if a parsing bug found no rows
// at all; these literals do not depend on the parser). The encoder must produce these bytes and
// the decoder must read them back as the message the row describes.
void expect_doc_frame(const Message& m, std::uint16_t seq, const Bytes& wire) {
    SCOPED_TRACE(type_name(static_cast<std::uint8_t>(m.type)));
    EXPECT_EQ(test::hex(test::encode(m, seq)), test::hex(wire));
    FrameDecoder decoder;
    const auto events = test::decode_stream(decoder, wire);
    ASSERT_EQ(events.size(), 1u);
    EXPECT_EQ(events[0].status, FrameStatus::Ok) << status_name(events[0].status);
    EXPECT_EQ(events[0].seq, seq);
    EXPECT_TRUE(events[0].message == m);
}

TEST(PayloadLayout, ProtocolMdButtonEventFrame) {
    // ex-button-event: ButtonEvent, seq 4: t = 2 500 000 us, button 0 pressed
    expect_doc_frame(ButtonEvent{2'500'000, 0, ButtonState::Pressed}, 4,
                     {0x04, 0x01, 0x05, 0x04, 0x04, 0xa0, 0x25, 0x26, 0x01, 0x01,
                      0x01, 0x01, 0x01, 0x06, 0x01, 0x17, 0xf7, 0x41, 0xfc, 0x00});
}

TEST(PayloadLayout, ProtocolMdHelloRequestFrame) {
    // ex-hello-request: HelloRequest, appliance seq 0; body 01 10 00 00 | CRC 0xE5809CF5
    expect_doc_frame(HelloRequest{}, 0, {0x03, 0x01, 0x10, 0x01, 0x05, 0xf5, 0x9c, 0x80, 0xe5, 0x00});
}

TEST(PayloadLayout, ProtocolMdOrientationFrame) {
    // ex-orientation: seq 1, t = 1 000 000 us, w = y = Q30 0x2D413CCD, x = z = 0
    expect_doc_frame(Orientation{1'000'000, 0x2D413CCD, 0, 0x2D413CCD, 0}, 1,
                     {0x04, 0x01, 0x02, 0x01, 0x04, 0x40, 0x42, 0x0f, 0x01, 0x01, 0x01, 0x01,
                      0x05, 0xcd, 0x3c, 0x41, 0x2d, 0x01, 0x01, 0x01, 0x05, 0xcd, 0x3c, 0x41,
                      0x2d, 0x01, 0x01, 0x01, 0x05, 0xc6, 0x77, 0x88, 0xc9, 0x00});
}

TEST(PayloadLayout, ProtocolMdConfigAckFrame) {
    // ex-config-ack: seq 7, answers appliance seq 2, key 1, Ok, U32 100
    expect_doc_frame(ConfigAck{2, 1, ConfigStatus::Ok, ConfigValue::from_u32(100)}, 7,
                     {0x04, 0x01, 0x08, 0x07, 0x02, 0x02, 0x02, 0x01, 0x01, 0x01,
                      0x02, 0x64, 0x01, 0x01, 0x05, 0xfd, 0x7d, 0x99, 0xea, 0x00});
}

}  // namespace
}  // namespace glint::protocol
