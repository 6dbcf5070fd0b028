// The byte layout of headers and records: round trips, and clear errors for files that are not
// recordings, are of a newer major version, or whose header is cut or damaged.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "firmware_bridge/protocol/byte_io.hpp"
#include "firmware_bridge/protocol/crc32c.hpp"
#include "firmware_bridge/recording/format.hpp"
#include "recording_test_support.hpp"

namespace glint::recording {
namespace {

using test::sample_header;

std::string parse_error(std::span<const std::uint8_t> bytes) {
    try {
        parse_header(bytes);
    } catch (const FormatError& e) {
        return e.what();
    }
    return "";
}

TEST(RecordingFormat, HeaderRoundTrip) {
    const FileHeader h = sample_header();
    const Bytes bytes = encode_header(h);
    FileHeader parsed = parse_header(bytes);
    EXPECT_EQ(parsed.header_size, bytes.size());
    parsed.header_size = 0;  // the only field the writer fills in
    EXPECT_EQ(parsed, h);
}

TEST(RecordingFormat, MinimalHeaderHasTheDocumentedSize) {
    const Bytes bytes = encode_header(FileHeader{});
    EXPECT_EQ(bytes.size(), kMinHeaderSize);
    EXPECT_EQ(protocol::byte_io::get_u32(bytes.data() + 12), kMinHeaderSize);
    EXPECT_TRUE(std::equal(kMagic.begin(), kMagic.end(), bytes.begin()));
}

TEST(RecordingFormat, HeaderLayoutMatchesFormatMd) {
    // FORMAT.md section 2, field by field, for the sample header.
    const FileHeader h = sample_header();
    const Bytes b = encode_header(h);
    namespace bio = protocol::byte_io;
    EXPECT_EQ(bio::get_u16(b.data() + 8), kFormatMajor);
    EXPECT_EQ(bio::get_u16(b.data() + 10), kFormatMinor);
    EXPECT_EQ(bio::get_u64(b.data() + 16), static_cast<std::uint64_t>(h.created_unix_us));
    EXPECT_EQ(bio::get_u64(b.data() + 24), h.created_monotonic_us);
    EXPECT_EQ(b[32], static_cast<std::uint8_t>(Transport::Serial));
    EXPECT_EQ(b[33], protocol::kVersionMajor);
    EXPECT_EQ(b[34], protocol::kVersionMinor);
    EXPECT_EQ(b[35], h.decoded_types.size());
    EXPECT_EQ(bio::get_u32(b.data() + 36), 230400u);
    const std::size_t device_at = 40 + h.decoded_types.size();
    EXPECT_EQ(bio::get_u16(b.data() + device_at), h.device.size());
    EXPECT_EQ(std::string(b.begin() + static_cast<std::ptrdiff_t>(device_at + 2),
                          b.begin() + static_cast<std::ptrdiff_t>(device_at + 2 + h.device.size())),
              h.device);
    const auto checked = std::span<const std::uint8_t>(b).first(b.size() - 4);
    EXPECT_EQ(bio::get_u32(b.data() + b.size() - 4), protocol::crc32c(checked));
}

TEST(RecordingFormat, NotARecording) {
    const std::string text = "#!/bin/sh\necho this is not a recording\n";
    const Bytes bytes(text.begin(), text.end());
    EXPECT_NE(parse_error(bytes).find("not a Glint recording"), std::string::npos);
}

TEST(RecordingFormat, NewerMajorVersionIsRefusedByName) {
    Bytes bytes = encode_header(sample_header());
    protocol::byte_io::put_u16(bytes.data() + 8, kFormatMajor + 1);
    const std::string e = parse_error(bytes);
    EXPECT_NE(e.find("format 2.0"), std::string::npos) << e;
    EXPECT_NE(e.find("newer"), std::string::npos) << e;
}

TEST(RecordingFormat, NewerMinorVersionWithAppendedFieldsIsRead) {
    // A 1.1 writer appends 6 bytes of new fields before the CRC: a 1.0 reader skips them.
    FileHeader h = sample_header();
    Bytes bytes = encode_header(h);
    // erase, not resize(size() - N): with the sanitizers GCC 12 loses that bound and warns
    // (-Warray-bounds, -Wstringop-overflow) about the memset on resize's growth path.
    bytes.erase(bytes.end() - 4, bytes.end());
    bytes.insert(bytes.end(), {1, 2, 3, 4, 5, 6});
    protocol::byte_io::put_u16(bytes.data() + 10, kFormatMinor + 1);
    protocol::byte_io::put_u32(bytes.data() + 12, static_cast<std::uint32_t>(bytes.size() + 4));
    const std::uint32_t crc = protocol::crc32c(bytes);
    bytes.resize(bytes.size() + 4);
    protocol::byte_io::put_u32(bytes.data() + bytes.size() - 4, crc);
    const FileHeader parsed = parse_header(bytes);
    EXPECT_EQ(parsed.format_minor, kFormatMinor + 1);
    EXPECT_EQ(parsed.notes, h.notes);
    EXPECT_EQ(parsed.device, h.device);
}

TEST(RecordingFormat, TruncatedHeaderNamesTheOffset) {
    const Bytes bytes = encode_header(sample_header());
    for (std::size_t n = 1; n < bytes.size(); ++n) {
        const std::string e = parse_error(std::span<const std::uint8_t>(bytes).first(n));
        EXPECT_NE(e.find("truncated header"), std::string::npos) << n << ": " << e;
        EXPECT_NE(e.find("byte " + std::to_string(n)), std::string::npos) << n << ": " << e;
    }
}

TEST(RecordingFormat, DamagedHeaderFailsItsCrcOrLimits) {
    const Bytes good = encode_header(sample_header());
    for (std::size_t i = 16; i < good.size(); ++i) {
        Bytes bad = good;
        bad[i] ^= 0x20;
        const std::string e = parse_error(bad);
        EXPECT_NE(e.find("header CRC mismatch at byte " + std::to_string(good.size() - 4)), std::string::npos)
            << i << ": " << e;
    }
    Bytes huge = good;
    protocol::byte_io::put_u32(huge.data() + 12, 0xFFFFFFF0u);
    EXPECT_NE(parse_error(huge).find("header size"), std::string::npos);
}

TEST(RecordingFormat, HeaderFieldRunningPastItsEndIsReported) {
    // A device length that claims more bytes than the header has, with a correct CRC (as a
    // buggy writer would produce): an error naming the field and its offset, no overread.
    FileHeader h;
    h.device = "abc";
    Bytes bytes = encode_header(h);
    protocol::byte_io::put_u16(bytes.data() + 40, 500);
    const std::uint32_t crc = protocol::crc32c(std::span<const std::uint8_t>(bytes).first(bytes.size() - 4));
    protocol::byte_io::put_u32(bytes.data() + bytes.size() - 4, crc);
    const std::string e = parse_error(bytes);
    EXPECT_NE(e.find("device at byte 42 of the header runs past its end"), std::string::npos) << e;
}

TEST(RecordingFormat, BadNotesAreRefusedWhenWriting) {
    FileHeader h;
    h.notes = {{"a=b", "x"}};
    EXPECT_THROW(encode_header(h), FormatError);
    h.notes = {{"", "x"}};
    EXPECT_THROW(encode_header(h), FormatError);
    h.notes = {{"k", "line\nbreak"}};
    EXPECT_THROW(encode_header(h), FormatError);
    h.notes = {{"k", std::string(70000, 'x')}};
    EXPECT_THROW(encode_header(h), FormatError);
}

std::vector<RecordBody> one_of_each() {
    return {
        RawBytesRecord{123, 456, Direction::Received, {0x00, 0x01, 0xAB, 'R', 'E', 'C', 0xFF}},
        RawBytesRecord{124, 0, Direction::Sent, {}},
        DecodedMessageRecord{200, 7, 65535,
                             protocol::Orientation{99, protocol::kQ30One, 0, 0, 0}},
        DecodedMessageRecord{201, 8, 1,
                             protocol::RawImu{100, {1, -2, 3}, {4, 9'806'650, -6}, {7, 8, -9}, 7}},
        GpioEventRecord{300, 17, Edge::Falling, "gpiochip0"},
        MarkerRecord{400, "capture started"},
        MarkerRecord{401, ""},
        StreamRestartRecord{500, "port reopened"},
        UnknownRecord{0x7001, 0x0003, {1, 2, 3}},
    };
}

TEST(RecordingFormat, RecordRoundTripEveryKind) {
    for (const RecordBody& body : one_of_each()) {
        const Bytes bytes = encode_record(body);
        EXPECT_EQ(protocol::byte_io::get_u16(bytes.data() + 8), record_type_of(body));
        const RecordParse p = parse_record(bytes);
        ASSERT_EQ(p.check, RecordCheck::Ok) << record_type_name(record_type_of(body)) << " " << p.detail;
        EXPECT_EQ(p.size, bytes.size());
        EXPECT_TRUE(*p.body == body) << record_type_name(record_type_of(body));
    }
}

TEST(RecordingFormat, RecordChecksInOrder) {
    const Bytes good = encode_record(MarkerRecord{1, "hello"});
    // Every prefix is incomplete, never an error or an overread.
    for (std::size_t n = 0; n < good.size(); ++n)
        EXPECT_EQ(parse_record(std::span<const std::uint8_t>(good).first(n)).check, RecordCheck::NeedMore) << n;
    Bytes bad_sync = good;
    bad_sync[1] = 'X';
    EXPECT_EQ(parse_record(bad_sync).check, RecordCheck::BadSync);
    Bytes bad_size = good;
    protocol::byte_io::put_u32(bad_size.data() + 4, kMaxRecordPayload + 1);
    EXPECT_EQ(parse_record(bad_size).check, RecordCheck::BadSize);
    for (std::size_t i = 4; i < good.size(); ++i) {
        if (i >= 4 && i < 8) continue;  // a changed size is NeedMore or BadSize, checked above
        Bytes bad = good;
        bad[i] ^= 0x01;
        EXPECT_EQ(parse_record(bad).check, RecordCheck::BadCrc) << i;
    }
}

// Re-signs a record after changing its payload, as a buggy writer would.
Bytes resign(Bytes record) {
    namespace bio = protocol::byte_io;
    std::uint32_t reg = protocol::crc32c_update(protocol::kCrc32cInit, std::span<const std::uint8_t>(record).subspan(4, 8));
    reg = protocol::crc32c_update(reg, std::span<const std::uint8_t>(record).subspan(16));
    bio::put_u32(record.data() + 12, protocol::crc32c_finish(reg));
    return record;
}

TEST(RecordingFormat, MalformedPayloadWithRightCrc) {
    Bytes raw = encode_record(RawBytesRecord{1, 2, Direction::Received, {9}});
    raw[16 + 16] = 7;  // direction 7
    RecordParse p = parse_record(resign(raw));
    EXPECT_EQ(p.check, RecordCheck::Malformed);
    EXPECT_NE(p.detail.find("direction 7"), std::string::npos) << p.detail;

    Bytes gpio = encode_record(GpioEventRecord{1, 2, Edge::Rising, ""});
    gpio.pop_back();  // edge byte missing
    protocol::byte_io::put_u32(gpio.data() + 4, static_cast<std::uint32_t>(gpio.size() - 16));
    p = parse_record(resign(gpio));
    EXPECT_EQ(p.check, RecordCheck::Malformed);
    EXPECT_NE(p.detail.find("gpio edge at byte 28 of the record runs past its end"), std::string::npos) << p.detail;

    // A decoded orientation whose quaternion is all zeros is not a valid message.
    Bytes msg = encode_record(DecodedMessageRecord{1, 2, 3, protocol::Orientation{5, protocol::kQ30One, 0, 0, 0}});
    protocol::byte_io::put_u32(msg.data() + 16 + 19 + 8, 0);
    p = parse_record(resign(msg));
    EXPECT_EQ(p.check, RecordCheck::Malformed);
    EXPECT_NE(p.detail.find("does not decode"), std::string::npos) << p.detail;
}

// The hex of a FORMAT.md example row "| `name` | what | `hex` |"; empty when missing.
std::string doc_example(const std::string& name) {
    std::ifstream doc(GLINT_RECORDING_FORMAT_DOC);
    std::string line;
    const std::string key = "| `" + name + "` |";
    while (std::getline(doc, line)) {
        if (line.rfind(key, 0) != 0) continue;
        const std::size_t end = line.rfind('`');
        const std::size_t begin = line.rfind('`', end - 1);
        return line.substr(begin + 1, end - begin - 1);
    }
    return "";
}

std::string hex(const Bytes& bytes) {
    std::string out;
    char b[4];
    for (std::size_t i = 0; i < bytes.size(); ++i) {
        std::snprintf(b, sizeof b, i ? " %02x" : "%02x", static_cast<unsigned>(bytes[i]));
        out += b;
    }
    return out;
}

TEST(RecordingFormat, DocExamples) {
    FileHeader h;
    h.created_unix_us = 1'735'689'600'000'000;
    h.created_monotonic_us = 7'200'000'000;
    h.transport = Transport::Serial;
    h.baud = 115200;
    h.decoded_types = {2};
    h.device = "/dev/ttyACM0";
    h.notes = {{"site", "lab"}};
    const std::pair<std::string, Bytes> examples[] = {
        {"ex-header", encode_header(h)},
        {"ex-marker", encode_record(MarkerRecord{7'200'001'000, "start"})},
        {"ex-raw", encode_record(RawBytesRecord{7'200'002'000, 0, Direction::Received,
                                                {0x03, 0x01, 0x10, 0x01, 0x05, 0xf5, 0x9c, 0x80, 0xe5, 0x00}})},
        {"ex-decoded", encode_record(DecodedMessageRecord{
                           7'200'003'000, 25, 1, protocol::Orientation{1'000'000, 0x2D413CCD, 0, 0x2D413CCD, 0}})},
        {"ex-gpio", encode_record(GpioEventRecord{7'200'004'000, 17, Edge::Rising, "gpiochip0"})},
        {"ex-restart", encode_record(StreamRestartRecord{7'200'005'000, "reopened"})},
    };
    for (const auto& [name, bytes] : examples)
        EXPECT_EQ(doc_example(name), hex(bytes)) << "FORMAT.md row " << name << " should read:\n| `" << name
                                                 << "` | ... | `" << hex(bytes) << "` |";
    EXPECT_EQ(parse_header(examples[0].second).header_size, 72u);
}

TEST(RecordingFormat, TransportNames) {
    for (std::uint8_t v = 0; v <= 5; ++v) {
        const auto t = static_cast<Transport>(v);
        EXPECT_EQ(transport_from_name(transport_name(t)), t);
    }
    EXPECT_FALSE(transport_from_name("carrier pigeon"));
}

}  // namespace
}  // namespace glint::recording
