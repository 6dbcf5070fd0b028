// Damage in the middle of a recording: a damaged record is reported with its byte offset and
// skipped, reading resumes at the next intact record (sync marker + CRC), and no damaged byte
// ever comes back as data. Random files never crash the reader.
#include <gtest/gtest.h>

#include <map>
#include <random>
#include <set>

#include "firmware_bridge/protocol/byte_io.hpp"
#include "firmware_bridge/protocol/crc32c.hpp"
#include "firmware_bridge/recording/player.hpp"
#include "firmware_bridge/recording/verify.hpp"
#include "recording_test_support.hpp"

namespace glint::recording {
namespace {

struct SmallFile {
    Bytes bytes;
    std::vector<Record> records;
    std::uint64_t header_size = 0;
};

SmallFile small_file() {
    test::TempDir dir;
    VirtualClock clock;
    test::write_small_recording(dir.file("f.glrec"), clock);
    SmallFile f;
    f.bytes = test::read_file(dir.file("f.glrec"));
    RecordingReader reader(Bytes(f.bytes), "f");
    f.records = test::read_all(reader);
    f.header_size = reader.header().header_size;
    return f;
}

TEST(RecordingCorruption, OneDamagedRecordIsSkippedWithItsOffset) {
    const SmallFile f = small_file();
    for (std::size_t victim = 0; victim < f.records.size(); ++victim) {
        // Every byte position of the record: sync, size, type, CRC, payload.
        const Record& v = f.records[victim];
        for (std::uint32_t at = 0; at < v.size; ++at) {
            SCOPED_TRACE("record " + std::to_string(victim) + " byte " + std::to_string(at));
            Bytes damaged = f.bytes;
            damaged[v.offset + at] ^= 0x5A;
            RecordingReader reader(damaged, "d.glrec");
            const auto got = test::read_all(reader);
            ASSERT_EQ(got.size(), f.records.size() - 1);
            for (std::size_t i = 0, j = 0; i < f.records.size(); ++i) {
                if (i == victim) continue;
                EXPECT_EQ(got[j].offset, f.records[i].offset);
                EXPECT_TRUE(got[j].body == f.records[i].body);
                ++j;
            }
            ASSERT_EQ(reader.issues().size(), 1u);
            const ReadIssue& issue = reader.issues()[0];
            EXPECT_EQ(issue.offset, v.offset);
            const bool last = victim + 1 == f.records.size();
            EXPECT_EQ(issue.kind, last ? IssueKind::TornTail : IssueKind::CorruptRecord);
            EXPECT_EQ(issue.size, v.size);
            EXPECT_NE(issue.message.find("at byte " + std::to_string(v.offset)), std::string::npos) << issue.message;
        }
    }
}

TEST(RecordingCorruption, RandomDamageNeverReturnsDamagedBytes) {
    const SmallFile f = small_file();
    std::map<std::uint64_t, const Record*> by_offset;
    for (const Record& r : f.records) by_offset[r.offset] = &r;
    std::mt19937_64 random(20240607);
    for (int trial = 0; trial < 3000; ++trial) {
        Bytes damaged = f.bytes;
        std::set<std::uint64_t> hit;  // offsets of records with a changed byte
        const int flips = 1 + static_cast<int>(random() % 6);
        for (int k = 0; k < flips; ++k) {
            const std::uint64_t at = f.header_size + random() % (f.bytes.size() - f.header_size);
            const auto value = static_cast<std::uint8_t>(random());
            if (damaged[at] == value) continue;
            damaged[at] = value;
            hit.insert(std::prev(by_offset.upper_bound(at))->first);
        }
        RecordingReader reader(damaged, "r.glrec");
        const auto got = test::read_all(reader);
        std::set<std::uint64_t> returned;
        for (const Record& r : got) {
            // Every record returned is an original, undamaged one at its original place.
            ASSERT_TRUE(by_offset.count(r.offset)) << "trial " << trial << " offset " << r.offset;
            EXPECT_FALSE(hit.count(r.offset)) << "trial " << trial;
            EXPECT_TRUE(r.body == by_offset[r.offset]->body) << "trial " << trial;
            returned.insert(r.offset);
        }
        // ... and every undamaged record is returned.
        for (const Record& r : f.records)
            if (!hit.count(r.offset)) {
                EXPECT_TRUE(returned.count(r.offset)) << "trial " << trial << " lost " << r.offset;
            }
        // The first damaged record is where the first issue starts.
        if (!hit.empty()) {
            ASSERT_FALSE(reader.issues().empty()) << "trial " << trial;
            EXPECT_EQ(reader.issues()[0].offset, *hit.begin());
        }
    }
}

TEST(RecordingCorruption, RandomFilesNeverCrash) {
    std::mt19937_64 random(77);
    const Bytes header = encode_header(test::sample_header());
    for (int trial = 0; trial < 2000; ++trial) {
        Bytes bytes;
        if (trial % 2 == 0) bytes = header;  // a valid header then garbage, or garbage only
        const std::size_t n = random() % 3000;
        for (std::size_t i = 0; i < n; ++i) {
            // Sprinkle sync markers so the resynchronisation path is exercised.
            if (random() % 50 == 0) bytes.insert(bytes.end(), kRecordSync.begin(), kRecordSync.end());
            else bytes.push_back(static_cast<std::uint8_t>(random()));
        }
        try {
            RecordingReader reader(bytes, "random");
            VirtualClock clock;
            Player player(reader, clock);
            PlaybackSink sink;
            const PlaybackResult result = player.play(sink);
            EXPECT_EQ(result.records, 0u);  // a 1-in-2^32 CRC match aside, garbage has no records
        } catch (const RecordingError&) {
            EXPECT_NE(trial % 2, 0) << "a valid header was refused";
        }
    }
}

TEST(RecordingCorruption, DamagedRawRecordShowsAsStreamGapAndFailsVerify) {
    const SmallFile f = small_file();
    // The third record is a received chunk (after the marker and the first chunk).
    const Record& victim = f.records[3];
    ASSERT_TRUE(std::holds_alternative<RawBytesRecord>(victim.body));
    Bytes damaged = f.bytes;
    damaged[victim.offset + kRecordHeaderSize + 20] ^= 0xFF;
    RecordingReader reader(damaged, "gap.glrec");
    const VerifyReport report = verify_recording(reader);
    ASSERT_EQ(report.issues.size(), 2u);
    EXPECT_EQ(report.issues[0].kind, IssueKind::CorruptRecord);
    EXPECT_EQ(report.issues[0].offset, victim.offset);
    EXPECT_EQ(report.issues[1].kind, IssueKind::StreamGap);
    EXPECT_EQ(report.issues[1].size, std::get<RawBytesRecord>(victim.body).bytes.size());
    EXPECT_FALSE(report.intact());
    EXPECT_FALSE(report.replay_matches());  // the frame cut by the gap is not decoded again
}

TEST(RecordingCorruption, MalformedAndUnknownRecords) {
    const SmallFile f = small_file();
    // Append a record of an unknown type (a newer minor's) and a malformed one with a right CRC.
    Bytes bytes = f.bytes;
    const Bytes unknown = encode_record(UnknownRecord{0x0100, 0, {1, 2, 3}});
    bytes.insert(bytes.end(), unknown.begin(), unknown.end());
    Bytes bad = encode_record(GpioEventRecord{1, 2, Edge::Rising, ""});
    bad[16 + 12] = 9;  // edge 9
    std::uint32_t reg = protocol::crc32c_update(protocol::kCrc32cInit, std::span<const std::uint8_t>(bad).subspan(4, 8));
    reg = protocol::crc32c_update(reg, std::span<const std::uint8_t>(bad).subspan(16));
    protocol::byte_io::put_u32(bad.data() + 12, protocol::crc32c_finish(reg));
    const std::uint64_t bad_offset = bytes.size();
    bytes.insert(bytes.end(), bad.begin(), bad.end());
    const Bytes marker = encode_record(MarkerRecord{9, "after"});
    bytes.insert(bytes.end(), marker.begin(), marker.end());

    RecordingReader reader(bytes, "m.glrec");
    const auto got = test::read_all(reader);
    ASSERT_EQ(got.size(), f.records.size() + 2);
    EXPECT_TRUE(std::holds_alternative<UnknownRecord>(got[f.records.size()].body));
    EXPECT_TRUE(got.back().body == RecordBody(MarkerRecord{9, "after"}));
    ASSERT_EQ(reader.issues().size(), 1u);
    EXPECT_EQ(reader.issues()[0].kind, IssueKind::MalformedRecord);
    EXPECT_EQ(reader.issues()[0].offset, bad_offset);
    EXPECT_NE(reader.issues()[0].message.find("gpio edge 9"), std::string::npos) << reader.issues()[0].message;
}

}  // namespace
}  // namespace glint::recording
