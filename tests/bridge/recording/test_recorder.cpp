// The Recorder against real files: what it writes reads back identically, its buffering and
// periodic sync follow the clock, and I/O failures name the file and the errno text.
#include <gtest/gtest.h>

#include <sys/resource.h>
#include <sys/stat.h>

#include <csignal>

#include "recording_test_support.hpp"

namespace glint::recording {
namespace {

using test::TempDir;

std::uint64_t file_size(const std::string& path) {
    struct stat st {};
    EXPECT_EQ(::stat(path.c_str(), &st), 0);
    return static_cast<std::uint64_t>(st.st_size);
}

TEST(Recorder, RoundTripGivesIdenticalRecords) {
    TempDir dir;
    VirtualClock clock(1'000);
    const std::string path = dir.file("small.glrec");
    const std::vector<RecordBody> expected = test::write_small_recording(path, clock);
    RecordingReader reader(path);
    FileHeader header = reader.header();
    header.header_size = 0;
    header.format_major = kFormatMajor;
    EXPECT_EQ(header, test::sample_header());
    const std::vector<Record> records = test::read_all(reader);
    EXPECT_TRUE(reader.issues().empty());
    ASSERT_EQ(records.size(), expected.size());
    std::uint64_t offset = reader.header().header_size;
    for (std::size_t i = 0; i < records.size(); ++i) {
        EXPECT_TRUE(records[i].body == expected[i]) << "record " << i;
        EXPECT_EQ(records[i].offset, offset) << "record " << i;  // back to back, no gaps
        offset += records[i].size;
    }
    EXPECT_EQ(offset, reader.file_size());
}

TEST(Recorder, FillsCreationTimesWhenNotGiven) {
    TempDir dir;
    VirtualClock clock(42'000'000);
    {
        Recorder recorder(dir.file("a.glrec"), RecorderOptions{}, clock);
        EXPECT_TRUE(recorder.close());
    }
    RecordingReader reader(dir.file("a.glrec"));
    EXPECT_EQ(reader.header().created_monotonic_us, 42'000'000u);
    EXPECT_GT(reader.header().created_unix_us, 1'600'000'000'000'000);  // after 2020
    EXPECT_FALSE(reader.next());
}

TEST(Recorder, LargeChunksAreSplitWithContinuousOffsets) {
    TempDir dir;
    VirtualClock clock;
    Bytes big(kMaxRawChunk * 2 + 100);
    for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<std::uint8_t>(i * 7);
    {
        Recorder recorder(dir.file("big.glrec"), RecorderOptions{}, clock);
        EXPECT_TRUE(recorder.on_bytes(77, big));
        EXPECT_EQ(recorder.records_written(), 3u);
        EXPECT_TRUE(recorder.close());
    }
    RecordingReader reader(dir.file("big.glrec"));
    Bytes joined;
    std::uint64_t expected_offset = 0;
    while (const auto r = reader.next()) {
        const auto& raw = std::get<RawBytesRecord>(r->body);
        EXPECT_EQ(raw.stream_offset, expected_offset);
        EXPECT_EQ(raw.time_us, 77u);
        expected_offset += raw.bytes.size();
        joined.insert(joined.end(), raw.bytes.begin(), raw.bytes.end());
    }
    EXPECT_EQ(joined, big);
}

TEST(Recorder, OnSampleKeepsOnlyOkFramesOfRecordedTypes) {
    TempDir dir;
    VirtualClock clock;
    RecorderOptions options;
    options.header.decoded_types = {static_cast<std::uint8_t>(protocol::MessageType::Orientation)};
    Recorder recorder(dir.file("s.glrec"), options, clock);
    protocol::FrameEvent ok;
    ok.status = protocol::FrameStatus::Ok;
    ok.offset = 34;
    ok.seq = 9;
    ok.message = protocol::Orientation{5, protocol::kQ30One, 0, 0, 0};
    protocol::FrameEvent rejected = ok;
    rejected.status = protocol::FrameStatus::CrcError;
    protocol::FrameEvent heartbeat = ok;
    heartbeat.message = protocol::Heartbeat{1, 2, 3, 4, 5, 6};
    EXPECT_TRUE(recorder.on_sample(100, ok));
    EXPECT_TRUE(recorder.on_sample(101, rejected));
    EXPECT_TRUE(recorder.on_sample(102, heartbeat));
    // An invalid message is refused without failing the recording.
    EXPECT_FALSE(recorder.on_message(103, 0, 0, protocol::Orientation{5, 0, 0, 0, 0}));
    EXPECT_TRUE(recorder.ok());
    EXPECT_TRUE(recorder.close());
    RecordingReader reader(dir.file("s.glrec"));
    const auto records = test::read_all(reader);
    ASSERT_EQ(records.size(), 1u);
    EXPECT_TRUE(records[0].body == RecordBody(DecodedMessageRecord{100, 34, 9, ok.message}));
}

TEST(Recorder, BuffersInBlocksAndSyncsOnTheInterval) {
    TempDir dir;
    VirtualClock clock(0);
    RecorderOptions options;
    options.block_size = 4096;
    options.sync_interval_us = 500'000;
    const std::string path = dir.file("sync.glrec");
    Recorder recorder(path, options, clock);
    const std::uint64_t header_size = file_size(path);
    const Bytes chunk(100, 0x55);
    // Less than a block, before the interval: nothing reaches the file yet.
    for (int i = 0; i < 10; ++i) recorder.on_bytes(static_cast<std::uint64_t>(i), chunk);
    EXPECT_EQ(file_size(path), header_size);
    EXPECT_EQ(recorder.syncs(), 0u);
    // A full block is written (not yet synced: the interval has not passed).
    for (int i = 0; i < 40; ++i) recorder.on_bytes(static_cast<std::uint64_t>(i), chunk);
    EXPECT_GT(file_size(path), header_size);
    EXPECT_EQ(recorder.syncs(), 0u);
    // Once the interval has passed, the next append writes and syncs everything.
    clock.advance_us(500'000);
    recorder.mark("tick");
    EXPECT_EQ(recorder.syncs(), 1u);
    RecordingReader mid(path);  // readable while still open
    EXPECT_EQ(test::read_all(mid).size(), 51u);
    EXPECT_TRUE(mid.issues().empty());
    // No new data: a later interval does not sync again.
    clock.advance_us(600'000);
    EXPECT_TRUE(recorder.flush());
    EXPECT_EQ(recorder.syncs(), 1u);
    recorder.mark("tock");
    EXPECT_TRUE(recorder.close());
    EXPECT_EQ(recorder.syncs(), 2u);
    EXPECT_FALSE(recorder.mark("after close"));
}

TEST(Recorder, RefusesToReplaceAFileUnlessTold) {
    TempDir dir;
    VirtualClock clock;
    const std::string path = dir.file("exists.glrec");
    test::write_file(path, Bytes{1, 2, 3});
    try {
        Recorder recorder(path, RecorderOptions{}, clock);
        FAIL() << "expected RecordingError";
    } catch (const RecordingError& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("File exists"), std::string::npos) << e.what();
    }
    RecorderOptions replace;
    replace.overwrite = true;
    Recorder recorder(path, replace, clock);
    EXPECT_TRUE(recorder.close());
    EXPECT_NO_THROW(RecordingReader{path});
}

TEST(Recorder, MissingDirectoryNamesThePath) {
    VirtualClock clock;
    try {
        Recorder recorder("/nonexistent-glint-dir/x.glrec", RecorderOptions{}, clock);
        FAIL() << "expected RecordingError";
    } catch (const RecordingError& e) {
        EXPECT_NE(std::string(e.what()).find("/nonexistent-glint-dir/x.glrec: No such file or directory"),
                  std::string::npos)
            << e.what();
    }
}

TEST(Recorder, FullDeviceFailsTheHeaderWrite) {
    VirtualClock clock;
    RecorderOptions options;
    options.overwrite = true;  // /dev/full exists
    try {
        Recorder recorder("/dev/full", options, clock);
        FAIL() << "expected RecordingError";
    } catch (const RecordingError& e) {
        EXPECT_NE(std::string(e.what()).find("/dev/full: No space left on device"), std::string::npos) << e.what();
    }
}

// Limits the file size of this process for one test (the kernel then fails write() with EFBIG
// instead of raising SIGXFSZ, which is ignored meanwhile).
class FileSizeLimit {
public:
    explicit FileSizeLimit(rlim_t bytes) {
        getrlimit(RLIMIT_FSIZE, &saved_);
        old_handler_ = std::signal(SIGXFSZ, SIG_IGN);
        rlimit limited = saved_;
        limited.rlim_cur = bytes;
        setrlimit(RLIMIT_FSIZE, &limited);
    }
    ~FileSizeLimit() {
        setrlimit(RLIMIT_FSIZE, &saved_);
        std::signal(SIGXFSZ, old_handler_);
    }

private:
    rlimit saved_{};
    void (*old_handler_)(int) = nullptr;
};

TEST(Recorder, WriteErrorIsReportedWithPathAndErrnoAndStopsTheRecording) {
    TempDir dir;
    VirtualClock clock;
    const std::string path = dir.file("limited.glrec");
    RecorderOptions options;
    options.block_size = 1024;
    Recorder recorder(path, options, clock);
    bool failed = false;
    {
        FileSizeLimit limit(8192);
        const Bytes chunk(200, 0x11);
        for (int i = 0; i < 200 && !failed; ++i) failed = !recorder.on_bytes(static_cast<std::uint64_t>(i), chunk);
    }
    ASSERT_TRUE(failed);
    EXPECT_FALSE(recorder.ok());
    EXPECT_NE(recorder.error().find(path), std::string::npos) << recorder.error();
    EXPECT_NE(recorder.error().find("write failed: File too large"), std::string::npos) << recorder.error();
    EXPECT_FALSE(recorder.mark("later"));
    EXPECT_FALSE(recorder.close());
    // What reached the file before the failure is readable; a cut record is a torn tail.
    RecordingReader reader(path);
    const auto records = test::read_all(reader);
    EXPECT_GT(records.size(), 10u);
    for (const ReadIssue& issue : reader.issues()) EXPECT_EQ(issue.kind, IssueKind::TornTail) << issue.message;
}

TEST(Recorder, FileThatCouldNotBeStartedIsRemoved) {
    TempDir dir;
    VirtualClock clock;
    const std::string path = dir.file("no-room.glrec");
    {
        FileSizeLimit limit(20);  // smaller than any header
        EXPECT_THROW(Recorder(path, RecorderOptions{}, clock), RecordingError);
    }
    EXPECT_FALSE(std::filesystem::exists(path));
}

}  // namespace
}  // namespace glint::recording
