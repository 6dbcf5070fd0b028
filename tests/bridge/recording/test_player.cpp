// Replay: deterministic, paced by the clock at the recorded times, identical to what the live
// decoder produced, independent of how the bytes were chunked, and reset at stream restarts.
#include <gtest/gtest.h>

#include <random>

#include "firmware_bridge/recording/player.hpp"
#include "firmware_bridge/recording/session_generator.hpp"
#include "firmware_bridge/recording/text.hpp"
#include "firmware_bridge/recording/verify.hpp"
#include "recording_test_support.hpp"

namespace glint::recording {
namespace {

// Everything the player reports, as comparable text, with the clock's time at each frame.
class TraceSink final : public PlaybackSink {
public:
    explicit TraceSink(Clock& clock) : clock_(clock) {}
    void on_frame(std::uint64_t t, const protocol::FrameEvent& e) override {
        frames.push_back({t, clock_.now_us(), e});
        trace.push_back("frame t=" + std::to_string(t) + " offset=" + std::to_string(e.offset) + " size=" +
                        std::to_string(e.size) + " " + protocol::status_name(e.status) +
                        (e.status == protocol::FrameStatus::Ok ? " " + describe_message(e.message) : ""));
    }
    void on_record(const Record& r) override {
        record_clock.push_back({record_time_us(r.body), clock_.now_us()});
        trace.push_back("record @" + std::to_string(r.offset) + " " + describe_record(r.body));
    }
    void on_issue(const ReadIssue& i) override { trace.push_back("issue " + i.message); }

    struct Frame {
        std::uint64_t host_time_us;
        std::uint64_t clock_us;
        protocol::FrameEvent event;
    };
    std::vector<Frame> frames;
    std::vector<std::pair<std::optional<std::uint64_t>, std::uint64_t>> record_clock;
    std::vector<std::string> trace;

private:
    Clock& clock_;
};

std::string generated_session(test::TempDir& dir, std::uint64_t seed = 3) {
    const std::string path = dir.file("session-" + std::to_string(seed) + ".glrec");
    SessionOptions options;
    options.seed = seed;
    options.duration_ms = 1500;
    generate_session(path, options, false);
    return path;
}

TEST(RecordingPlayer, TwoReplaysAreIdentical) {
    test::TempDir dir;
    RecordingReader reader(generated_session(dir));
    VirtualClock clock_a, clock_b;
    TraceSink a(clock_a), b(clock_b);
    const PlaybackResult ra = Player(reader, clock_a).play(a);
    const PlaybackResult rb = Player(reader, clock_b).play(b);
    ASSERT_GT(a.trace.size(), 100u);
    EXPECT_EQ(a.trace, b.trace);
    EXPECT_EQ(ra.stats, rb.stats);
    EXPECT_GT(ra.stats.frames_ok, 100u);
    // The generator injects garbage: the decoder must have rejected something.
    EXPECT_GT(ra.stats.bytes_discarded, 0u);
}

TEST(RecordingPlayer, ReplayReproducesTheRecordedDecodedMessages) {
    test::TempDir dir;
    RecordingReader reader(generated_session(dir, 11));
    const VerifyReport report = verify_recording(reader);
    EXPECT_TRUE(report.intact());
    EXPECT_TRUE(report.replay_matches()) << (report.mismatches.empty() ? "" : report.mismatches[0]);
    EXPECT_GT(report.recorded_messages, 100u);
    EXPECT_EQ(report.matching_messages, report.recorded_messages);
    // And independently of verify_recording: the Ok frames of the replay, field by field.
    VirtualClock clock;
    TraceSink sink(clock);
    Player(reader, clock).play(sink);
    std::vector<DecodedMessageRecord> replayed;
    for (const auto& f : sink.frames)
        if (f.event.status == protocol::FrameStatus::Ok)
            replayed.push_back({f.host_time_us, f.event.offset, f.event.seq, f.event.message});
    reader.rewind();
    std::vector<DecodedMessageRecord> recorded;
    while (const auto r = reader.next())
        if (const auto* m = std::get_if<DecodedMessageRecord>(&r->body)) recorded.push_back(*m);
    EXPECT_EQ(replayed, recorded);
}

TEST(RecordingPlayer, VerifyNoticesADecodedRecordThatDiffers) {
    // A recorder fed a wrong decoded message (as a buggy driver would): verify must say so.
    test::TempDir dir;
    VirtualClock clock;
    const std::string path = dir.file("wrong.glrec");
    {
        RecorderOptions options;
        options.header.decoded_types = board_message_types();
        Recorder recorder(path, options, clock);
        const Bytes frame = test::encode(protocol::Orientation{1000, protocol::kQ30One, 0, 0, 0}, 0);
        recorder.on_bytes(50, frame);
        recorder.on_message(50, 0, 0, protocol::Orientation{1001, protocol::kQ30One, 0, 0, 0});
        ASSERT_TRUE(recorder.close());
    }
    RecordingReader reader(path);
    const VerifyReport report = verify_recording(reader);
    EXPECT_TRUE(report.intact());
    EXPECT_FALSE(report.replay_matches());
    ASSERT_EQ(report.mismatches.size(), 1u);
    EXPECT_NE(report.mismatches[0].find("board_t=1001us"), std::string::npos) << report.mismatches[0];
    EXPECT_NE(report.mismatches[0].find("board_t=1000us"), std::string::npos) << report.mismatches[0];
}

TEST(RecordingPlayer, RecordedSpeedOnAVirtualClockDeliversAtRecordedTimes) {
    test::TempDir dir;
    RecordingReader reader(generated_session(dir));
    const std::uint64_t clock_start = 5'000'000;
    VirtualClock clock(clock_start);
    TraceSink sink(clock);
    const PlaybackResult result = Player(reader, clock).play(sink);
    ASSERT_FALSE(sink.frames.empty());
    // Each frame arrives when the clock reaches start + (receive time - first record time).
    for (const auto& f : sink.frames) EXPECT_EQ(f.clock_us, clock_start + (f.host_time_us - result.first_time_us));
    for (const auto& [t, at] : sink.record_clock)
        if (t) {
            EXPECT_EQ(at, clock_start + (*t - result.first_time_us));
        }
    EXPECT_EQ(clock.now_us(), clock_start + (result.last_time_us - result.first_time_us));
    EXPECT_GT(result.last_time_us - result.first_time_us, 1'400'000u);  // the 1.5 s session
}

// A clock that logs every sleep: the player must ask for non-decreasing deadlines (it never
// goes back in time) and never sleep past the end of the recording.
class LoggingClock final : public Clock {
public:
    std::uint64_t now_us() override { return now; }
    void sleep_until_us(std::uint64_t t) override {
        deadlines.push_back(t);
        if (t > now) now = t;
    }
    std::uint64_t now = 0;
    std::vector<std::uint64_t> deadlines;
};

TEST(RecordingPlayer, PacingDeadlinesFollowTheRecording) {
    test::TempDir dir;
    RecordingReader reader(generated_session(dir));
    LoggingClock clock;
    PlaybackSink sink;
    const PlaybackResult result = Player(reader, clock).play(sink);
    ASSERT_EQ(clock.deadlines.size(), result.records);
    EXPECT_TRUE(std::is_sorted(clock.deadlines.begin(), clock.deadlines.end()));
    EXPECT_EQ(clock.deadlines.front(), 0u);
    EXPECT_EQ(clock.deadlines.back(), result.last_time_us - result.first_time_us);
}

TEST(RecordingPlayer, SteadyClockSleepsUntilTheDeadline) {
    SteadyClock clock;
    const std::uint64_t target = clock.now_us() + 2'000;
    clock.sleep_until_us(target);
    EXPECT_GE(clock.now_us(), target);
    // A deadline in the past returns at once. The bound is loose (1 s) on purpose: it is not a
    // speed check but catches an unsigned "deadline - now" that would wait for ages.
    const std::uint64_t before = clock.now_us();
    clock.sleep_until_us(target - 1'000);
    EXPECT_LT(clock.now_us() - before, 1'000'000u);
}

// Records `stream` cut into chunks of random sizes, then replays it.
std::vector<std::string> replay_with_chunking(const Bytes& stream, std::uint64_t seed, test::TempDir& dir) {
    const std::string path = dir.file("chunks-" + std::to_string(seed) + ".glrec");
    VirtualClock clock;
    {
        Recorder recorder(path, RecorderOptions{}, clock);
        std::mt19937_64 random(seed);
        for (std::size_t i = 0; i < stream.size();) {
            const std::size_t n = std::min<std::size_t>(stream.size() - i, 1 + random() % 40);
            recorder.on_bytes(1000, std::span<const std::uint8_t>(stream).subspan(i, n));
            i += n;
        }
        EXPECT_TRUE(recorder.close());
    }
    RecordingReader reader(path);
    VirtualClock play_clock;
    TraceSink sink(play_clock);
    Player(reader, play_clock).play(sink);
    std::vector<std::string> frames;
    for (const std::string& line : sink.trace)
        if (line.rfind("frame", 0) == 0) frames.push_back(line);
    return frames;
}

TEST(RecordingPlayer, ChunkingDoesNotChangeTheDecodedFrames) {
    Bytes stream;
    for (std::uint16_t i = 0; i < 40; ++i) {
        const Bytes f = test::encode(protocol::Orientation{i * 5'000u, protocol::kQ30One, 0, 0, 0}, i);
        stream.insert(stream.end(), f.begin(), f.end());
        if (i % 7 == 3) stream.insert(stream.end(), {0xDE, 0xAD, 0x00});  // garbage frame
    }
    stream.insert(stream.end(), {0x05, 0x01, 0x02});  // cut off at the end
    test::TempDir dir;
    const auto reference = replay_with_chunking(stream, 1, dir);
    EXPECT_EQ(reference.size(), 40u + 6u + 1u);  // frames, garbage frames, TruncatedAtEnd
    for (std::uint64_t seed = 2; seed < 6; ++seed) EXPECT_EQ(replay_with_chunking(stream, seed, dir), reference);
}

TEST(RecordingPlayer, StreamRestartResetsTheDecoderAndSentBytesAreNotDecoded) {
    test::TempDir dir;
    VirtualClock clock;
    const std::string path = dir.file("small.glrec");
    test::write_small_recording(path, clock);
    RecordingReader reader(path);
    VirtualClock play_clock;
    TraceSink sink(play_clock);
    const PlaybackResult result = Player(reader, play_clock).play(sink);
    EXPECT_EQ(result.stream_restarts, 1u);
    EXPECT_TRUE(verify_recording(reader).replay_matches());
    // Second segment: a Hello at offset 0 again.
    ASSERT_FALSE(sink.frames.empty());
    const auto& last = sink.frames.back().event;
    EXPECT_EQ(last.status, protocol::FrameStatus::Ok);
    EXPECT_EQ(last.offset, 0u);
    EXPECT_EQ(last.message.type, protocol::MessageType::Hello);
    // Statistics summed over both segments: 7 + 1 Ok frames, 1 garbage frame; the sent
    // HelloRequest was not fed to the decoder.
    EXPECT_EQ(result.stats.frames_ok, 8u);
    EXPECT_EQ(result.stats.cobs_errors + result.stats.crc_errors + result.stats.too_short, 1u);
    for (const auto& f : sink.frames)
        if (f.event.status == protocol::FrameStatus::Ok) {
            EXPECT_NE(f.event.message.type, protocol::MessageType::HelloRequest);
        }
}

}  // namespace
}  // namespace glint::recording
