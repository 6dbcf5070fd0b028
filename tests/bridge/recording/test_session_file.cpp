// The committed example session (data/sessions/): it verifies, it is what the documented
// generator command writes (byte for byte), and the generator is deterministic.
#include <gtest/gtest.h>

#include "firmware_bridge/recording/session_generator.hpp"
#include "firmware_bridge/recording/verify.hpp"
#include "recording_test_support.hpp"

namespace glint::recording {
namespace {

const std::string kSession = std::string(GLINT_SESSIONS_DIR) + "/synthetic-rotation-4s.glrec";

TEST(RecordingSessionFile, CommittedSessionVerifies) {
    RecordingReader reader(kSession);
    EXPECT_LT(reader.file_size(), 200u * 1024u);
    EXPECT_EQ(reader.header().transport, Transport::Simulator);
    const VerifyReport report = verify_recording(reader);
    EXPECT_TRUE(report.intact());
    EXPECT_TRUE(report.replay_matches());
    EXPECT_GT(report.recorded_messages, 500u);
    // Garbage was injected and rejected, and it cost some frames.
    EXPECT_GT(report.playback.stats.bytes_discarded, 0u);
    EXPECT_GT(report.playback.stats.lost_frames, 0u);
    // It spans the documented ~4 s of appliance time.
    EXPECT_GT(report.playback.last_time_us - report.playback.first_time_us, 3'900'000u);
}

TEST(RecordingSessionFile, DocumentedGeneratorCommandReproducesIt) {
    // data/sessions/README.md: glint-recording generate --seed 1 --duration-ms 4000 FILE
    test::TempDir dir;
    SessionOptions options;
    options.seed = 1;
    options.duration_ms = 4000;
    generate_session(dir.file("again.glrec"), options, false);
    EXPECT_EQ(test::read_file(dir.file("again.glrec")), test::read_file(kSession));
}

TEST(RecordingSessionFile, OtherSeedsGiveOtherSessions) {
    test::TempDir dir;
    SessionOptions options;
    options.duration_ms = 500;
    options.seed = 1;
    generate_session(dir.file("a.glrec"), options, false);
    options.seed = 2;
    generate_session(dir.file("b.glrec"), options, false);
    EXPECT_NE(test::read_file(dir.file("a.glrec")), test::read_file(dir.file("b.glrec")));
}

}  // namespace
}  // namespace glint::recording
