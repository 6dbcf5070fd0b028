// CRC-32C check values and COBS encoding edge cases (empty, zeros, 254/255-byte runs, max frame).
#include <gtest/gtest.h>

#include <cstring>
#include <random>

#include "firmware_bridge/protocol/cobs.hpp"
#include "firmware_bridge/protocol/crc32c.hpp"
#include "protocol_test_support.hpp"

namespace glint::protocol {
namespace {

using test::Bytes;

Bytes ascii(const char* s) { return Bytes(s, s + std::strlen(s)); }

TEST(Crc32c, StandardCheckValueOf123456789) {
    EXPECT_EQ(crc32c(ascii("123456789")), 0xE3069283u);
    EXPECT_EQ(crc32c(ascii("123456789")), kCrc32cCheck);
}

TEST(Crc32c, KnownVectors) {
    // Empty input leaves init ^ xorout = 0; 32 zero bytes is the iSCSI (RFC 3720 B.4) vector.
    EXPECT_EQ(crc32c({}), 0x00000000u);
    EXPECT_EQ(crc32c(Bytes(32, 0x00)), 0x8A9136AAu);
    EXPECT_EQ(crc32c(Bytes(32, 0xFF)), 0x62A8AB43u);
}

TEST(Crc32c, IncrementalEqualsWholeAtEverySplit) {
    const Bytes data = ascii("The quick brown fox jumps over the lazy dog");
    const std::uint32_t whole = crc32c(data);
    for (std::size_t split = 0; split <= data.size(); ++split) {
        const std::span<const std::uint8_t> all(data);
        std::uint32_t reg = crc32c_update(kCrc32cInit, all.first(split));
        reg = crc32c_update(reg, all.subspan(split));
        EXPECT_EQ(crc32c_finish(reg), whole) << "split " << split;
    }
}

TEST(Crc32c, DetectsEverySingleBitFlip) {
    Bytes data = ascii("orientation frame body");
    const std::uint32_t good = crc32c(data);
    for (std::size_t bit = 0; bit < data.size() * 8; ++bit) {
        data[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
        EXPECT_NE(crc32c(data), good) << "bit " << bit;
        data[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    }
}

Bytes cobs_enc(const Bytes& in) {
    Bytes out(cobs_max_encoded_size(in.size()));
    const CobsResult r = cobs_encode(in, out);
    EXPECT_TRUE(r.ok);
    out.resize(r.size);
    return out;
}

Bytes cobs_dec(const Bytes& in, bool expect_ok = true) {
    Bytes out(in.size() + 1);
    const CobsResult r = cobs_decode(in, out);
    EXPECT_EQ(r.ok, expect_ok) << test::hex(in);
    out.resize(r.ok ? r.size : 0);
    return out;
}

Bytes iota_bytes(std::size_t n, std::uint8_t first) {
    Bytes b(n);
    for (std::size_t i = 0; i < n; ++i) b[i] = static_cast<std::uint8_t>(first + i);
    return b;
}

// Vectors from the COBS paper's rules, written out by hand: {input, encoding}.
TEST(Cobs, SmallVectors) {
    const std::vector<std::pair<Bytes, Bytes>> cases = {
        {{}, {0x01}},
        {{0x00}, {0x01, 0x01}},
        {{0x00, 0x00}, {0x01, 0x01, 0x01}},
        {{0x00, 0x11, 0x00}, {0x01, 0x02, 0x11, 0x01}},
        {{0x11, 0x22, 0x00, 0x33}, {0x03, 0x11, 0x22, 0x02, 0x33}},
        {{0x11, 0x22, 0x33, 0x44}, {0x05, 0x11, 0x22, 0x33, 0x44}},
        {{0x11, 0x00, 0x00, 0x00}, {0x02, 0x11, 0x01, 0x01, 0x01}},
    };
    for (const auto& [raw, encoded] : cases) {
        EXPECT_EQ(cobs_enc(raw), encoded) << test::hex(raw);
        EXPECT_EQ(cobs_dec(encoded), raw) << test::hex(encoded);
    }
}

TEST(Cobs, AllZeros) {
    for (std::size_t n : {1u, 2u, 253u, 254u, 255u, 600u}) {
        const Bytes zeros(n, 0);
        const Bytes enc = cobs_enc(zeros);
        EXPECT_EQ(enc, Bytes(n + 1, 0x01)) << n;
        EXPECT_EQ(cobs_dec(enc), zeros) << n;
    }
}

TEST(Cobs, Run254NonZeroIsOneFullBlock) {
    const Bytes raw = iota_bytes(254, 1);  // 01 .. FE
    const Bytes enc = cobs_enc(raw);
    ASSERT_EQ(enc.size(), 255u);
    EXPECT_EQ(enc[0], 0xFF);
    EXPECT_TRUE(std::equal(raw.begin(), raw.end(), enc.begin() + 1));
    EXPECT_EQ(cobs_dec(enc), raw);
}

TEST(Cobs, Run255NonZeroNeedsASecondBlock) {
    const Bytes raw = iota_bytes(255, 1);  // 01 .. FF
    const Bytes enc = cobs_enc(raw);
    ASSERT_EQ(enc.size(), 257u);
    EXPECT_EQ(enc[0], 0xFF);
    EXPECT_EQ(enc[255], 0x02);
    EXPECT_EQ(enc[256], 0xFF);
    EXPECT_EQ(cobs_dec(enc), raw);
}

TEST(Cobs, ZeroThen254NonZero) {
    Bytes raw{0x00};
    test::append(raw, iota_bytes(254, 1));
    const Bytes enc = cobs_enc(raw);
    ASSERT_EQ(enc.size(), 256u);
    EXPECT_EQ(enc[0], 0x01);
    EXPECT_EQ(enc[1], 0xFF);
    EXPECT_EQ(cobs_dec(enc), raw);
}

TEST(Cobs, Run254ThenZero) {
    Bytes raw = iota_bytes(254, 1);
    raw.push_back(0x00);
    const Bytes enc = cobs_enc(raw);
    ASSERT_EQ(enc.size(), 257u);
    EXPECT_EQ(enc[0], 0xFF);
    EXPECT_EQ(enc[255], 0x01);
    EXPECT_EQ(enc[256], 0x01);
    EXPECT_EQ(cobs_dec(enc), raw);
}

TEST(Cobs, MaxFrameBodyFitsMaxEncodedSize) {
    // The worst body for COBS is all non-zero; 254 bytes is the protocol's largest body.
    const Bytes body(kMaxBodySize, 0xA5);
    Bytes out(kMaxEncodedBodySize);
    const CobsResult r = cobs_encode(body, out);
    ASSERT_TRUE(r.ok);
    EXPECT_EQ(r.size, kMaxEncodedBodySize);
    EXPECT_EQ(cobs_dec(Bytes(out.begin(), out.end())), body);
}

TEST(Cobs, EncodedNeverContainsZeroAndRoundTripsRandomData) {
    std::mt19937 rng(20240611);
    for (int round = 0; round < 2000; ++round) {
        const std::size_t n = rng() % 700;
        const int zero_percent = static_cast<int>(rng() % 101);
        Bytes raw(n);
        for (auto& b : raw) b = (static_cast<int>(rng() % 100) < zero_percent) ? 0 : static_cast<std::uint8_t>(1 + rng() % 255);
        const Bytes enc = cobs_enc(raw);
        EXPECT_LE(enc.size(), cobs_max_encoded_size(n));
        EXPECT_EQ(std::count(enc.begin(), enc.end(), 0), 0);
        EXPECT_EQ(cobs_dec(enc), raw);
    }
}

TEST(Cobs, EncodeRefusesShortOutput) {
    const Bytes raw = iota_bytes(10, 1);
    for (std::size_t cap = 0; cap < 11; ++cap) {
        Bytes out(cap);
        EXPECT_FALSE(cobs_encode(raw, out).ok) << cap;
    }
    Bytes out(11);
    EXPECT_TRUE(cobs_encode(raw, out).ok);
}

TEST(Cobs, DecodeRejectsMalformedInput) {
    cobs_dec({0x00}, false);              // a code byte of zero
    cobs_dec({0x05, 0x11, 0x22}, false);  // a block longer than the input
    cobs_dec({0x03, 0x11, 0x00}, false);  // a zero data byte
    cobs_dec({0xFF, 0x01}, false);        // full block cut short
    Bytes small(1);
    EXPECT_FALSE(cobs_decode(Bytes{0x03, 0x11, 0x22}, small).ok);  // output too small
}

TEST(Cobs, NonCanonicalTrailingBlockDecodesToSameData) {
    // Some encoders add an empty 0x01 block after a final full block; accept it.
    Bytes enc{0xFF};
    test::append(enc, iota_bytes(254, 1));
    enc.push_back(0x01);
    EXPECT_EQ(cobs_dec(enc), iota_bytes(254, 1));
}

}  // namespace
}  // namespace glint::protocol
