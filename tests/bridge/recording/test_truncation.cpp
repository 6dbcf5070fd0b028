// A recording cut at every byte offset (power loss at any moment): never a crash, everything
// before the cut is read back intact, and the torn part is reported with its byte offset.
#include <gtest/gtest.h>

#include "firmware_bridge/recording/player.hpp"
#include "recording_test_support.hpp"

namespace glint::recording {
namespace {

class CountingSink final : public PlaybackSink {
public:
    void on_frame(std::uint64_t, const protocol::FrameEvent& e) override {
        if (e.status == protocol::FrameStatus::Ok) ++ok_frames;
    }
    std::uint64_t ok_frames = 0;
};

TEST(RecordingTruncation, EveryByteOffset) {
    test::TempDir dir;
    VirtualClock clock;
    const std::string path = dir.file("small.glrec");
    test::write_small_recording(path, clock);
    const Bytes full = test::read_file(path);
    RecordingReader full_reader(Bytes(full), "full");
    const std::vector<Record> all = test::read_all(full_reader);
    const std::uint64_t header_size = full_reader.header().header_size;
    ASSERT_GT(all.size(), 10u);

    for (std::size_t cut = 0; cut <= full.size(); ++cut) {
        SCOPED_TRACE("cut at byte " + std::to_string(cut));
        const Bytes part(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(cut));
        if (cut < header_size) {
            try {
                RecordingReader reader(part, "cut.glrec");
                ADD_FAILURE() << "a cut header was accepted";
            } catch (const RecordingError& e) {
                const std::string m = e.what();
                EXPECT_EQ(m.rfind("cut.glrec: ", 0), 0u) << m;
                const std::string want =
                    cut == 0 ? "empty" : "truncated header: the file ends at byte " + std::to_string(cut);
                EXPECT_NE(m.find(want), std::string::npos) << m;
            }
            continue;
        }
        RecordingReader reader(part, "cut.glrec");
        const std::vector<Record> got = test::read_all(reader);
        // Exactly the records that lie wholly before the cut.
        std::size_t whole = 0;
        while (whole < all.size() && all[whole].offset + all[whole].size <= cut) ++whole;
        ASSERT_EQ(got.size(), whole);
        for (std::size_t i = 0; i < whole; ++i) {
            EXPECT_EQ(got[i].offset, all[i].offset);
            EXPECT_TRUE(got[i].body == all[i].body) << "record " << i;
        }
        const bool at_boundary = whole == all.size() ? cut == full.size() : cut == all[whole].offset;
        if (at_boundary) {
            EXPECT_TRUE(reader.issues().empty());
        } else {
            ASSERT_EQ(reader.issues().size(), 1u);
            const ReadIssue& issue = reader.issues()[0];
            EXPECT_EQ(issue.kind, IssueKind::TornTail);
            EXPECT_EQ(issue.offset, all[whole].offset);
            EXPECT_EQ(issue.size, cut - all[whole].offset);
            EXPECT_NE(issue.message.find("torn record at byte " + std::to_string(all[whole].offset)), std::string::npos)
                << issue.message;
        }
        // The player copes too, and decodes no more than the whole file holds.
        CountingSink sink;
        VirtualClock play_clock;
        Player player(reader, play_clock);
        const PlaybackResult result = player.play(sink);
        EXPECT_EQ(result.records, whole);
        EXPECT_LE(sink.ok_frames, 8u);  // Hello + 6 Orientation + Hello after the restart
    }
}

TEST(RecordingTruncation, TruncatedFileOnDiskNamesPathAndOffset) {
    test::TempDir dir;
    VirtualClock clock;
    const std::string path = dir.file("cut.glrec");
    test::write_small_recording(path, clock);
    Bytes bytes = test::read_file(path);
    // erase, not resize(size() - N): with the sanitizers GCC 12 loses that bound and warns
    // (-Warray-bounds, -Wstringop-overflow) about the memset on resize's growth path.
    bytes.erase(bytes.end() - 3, bytes.end());
    test::write_file(path, bytes);
    RecordingReader reader(path);
    test::read_all(reader);
    ASSERT_EQ(reader.issues().size(), 1u);
    EXPECT_EQ(reader.issues()[0].message.rfind(path + ": torn record at byte ", 0), 0u) << reader.issues()[0].message;
}

TEST(RecordingTruncation, MissingFileAndDirectoryAreClearErrors) {
    test::TempDir dir;
    const std::string missing = dir.file("missing.glrec");
    try {
        RecordingReader reader(missing);
        FAIL();
    } catch (const RecordingError& e) {
        EXPECT_EQ(std::string(e.what()), missing + ": cannot open: No such file or directory");
    }
    EXPECT_THROW(RecordingReader{"/tmp"}, RecordingError);
}

}  // namespace
}  // namespace glint::recording
