// Recording a sensor that has no byte stream (a Modbus pan/tilt head here; an I2C BNO055 takes
// the same path): each published sample becomes a decoded Orientation record, and a replay of
// the file publishes the same samples, latency offset included; `verify` has nothing to replay
// them against and says so instead of failing.
#include <gtest/gtest.h>

#include <filesystem>
#include <mutex>

#include "appliance/core/rotation.hpp"
#include "firmware_bridge/host/modbus_head_sim.hpp"
#include "firmware_bridge/host/modbus_head_source.hpp"
#include "firmware_bridge/host/replay_source.hpp"
#include "firmware_bridge/host/sample_recording.hpp"
#include "firmware_bridge/recording/reader.hpp"
#include "firmware_bridge/recording/verify.hpp"
#include "host_test_support.hpp"

namespace glint::host {
namespace {

using test::Collector;
using test::eventually;
constexpr double kDeg = 3.14159265358979323846 / 180.0;

TEST(SampleRecording, AModbusHeadIsRecordedAndReplaysTheSamplesItPublished) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("glint_sample_rec_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::string file = (dir / "head.glrec").string();

    auto head = ModbusHeadSimulator::tcp();
    head->set_angles(30, 10);
    recording::SteadyClock clock;
    SourceOptions options;
    options.latency_offset_ns = 7'000'000;  // replayed with the same setting below
    const std::string spec_text = "modbus-tcp:127.0.0.1:" + std::to_string(head->port());
    auto source = ModbusHeadSource::tcp(spec_text, "127.0.0.1", head->port(), clock, options);
    const SourceSpec spec = parse_source_spec(spec_text);
    const std::optional<recording::RecorderOptions> record_options = recording_options_for(spec);
    ASSERT_TRUE(record_options);
    EXPECT_EQ(record_options->header.transport, recording::Transport::Modbus);
    recording::Recorder recorder(file, *record_options, clock);
    SampleRecorder sample_recorder(recorder, options.latency_offset_ns);
    Collector live;
    source->set_sample_callback([&](const OrientationSample& s) {
        EXPECT_TRUE(sample_recorder.record(s));
        live.add(s);
    });
    source->start();
    // The head turns while it is read: the samples differ, and their order matters.
    ASSERT_TRUE(eventually([&] { return live.count() >= 10; })) << source->health().last_error;
    head->set_angles(-120, 40);
    const std::size_t before = live.count();
    ASSERT_TRUE(eventually([&] { return live.count() >= before + 10; })) << source->health().last_error;
    source->stop();
    ASSERT_TRUE(recorder.close()) << recorder.error();

    ReplaySource replay("replay:" + file, file, ReplayPacing::Fast, options);
    Collector replayed;
    replayed.attach(replay);
    replay.run_to_end();
    ASSERT_EQ(replayed.count(), live.count());
    double worst_angle = 0;
    bool turned = false;
    for (std::size_t k = 0; k < live.samples.size(); ++k) {
        const OrientationSample& a = live.samples[k];
        const OrientationSample& b = replayed.samples[k];
        EXPECT_LE(std::llabs(a.t_ns - b.t_ns), 500) << k;  // microseconds in the file, rounded
        EXPECT_EQ(a.board_us, b.board_us) << k;
        worst_angle = std::max(worst_angle, angle_between(a.world_from_sensor, b.world_from_sensor));
        turned = turned || angle_between(a.world_from_sensor, head_orientation(-120 * kDeg, 40 * kDeg)) < 0.01 * kDeg;
    }
    EXPECT_LT(worst_angle, 1e-8);  // Q30
    EXPECT_TRUE(turned);
    EXPECT_EQ(replay.health().state, LinkState::Finished);
    EXPECT_EQ(replay.health().samples, live.count());

    recording::RecordingReader reader(file);
    EXPECT_EQ(reader.header().device, spec_text);
    const recording::VerifyReport report = recording::verify_recording(reader);
    EXPECT_TRUE(report.decoded_only);
    EXPECT_TRUE(report.replay_matches());
    EXPECT_TRUE(report.intact());
    EXPECT_EQ(report.recorded_messages, live.count());
    std::filesystem::remove_all(dir);
}

TEST(SampleRecording, EachLiveKindHasARecordingAndAReplayHasNone) {
    const auto transport_of = [](const std::string& text) {
        const std::optional<recording::RecorderOptions> o = recording_options_for(parse_source_spec(text));
        return o ? std::optional<recording::Transport>(o->header.transport) : std::nullopt;
    };
    EXPECT_EQ(transport_of("serial:/dev/ttyACM0"), recording::Transport::Serial);
    EXPECT_EQ(transport_of("i2c:/dev/i2c-1"), recording::Transport::I2c);
    EXPECT_EQ(transport_of("modbus-rtu:/dev/ttyUSB0"), recording::Transport::Modbus);
    EXPECT_EQ(transport_of("replay:session.glrec"), std::nullopt);
    EXPECT_TRUE(recording::transport_has_byte_stream(recording::Transport::Serial));
    EXPECT_TRUE(recording::transport_has_byte_stream(recording::Transport::Unknown));  // older files: as before
    EXPECT_FALSE(recording::transport_has_byte_stream(recording::Transport::I2c));
    EXPECT_FALSE(recording::transport_has_byte_stream(recording::Transport::Modbus));
}

}  // namespace
}  // namespace glint::host
