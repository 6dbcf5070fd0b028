#include <gtest/gtest.h>

#include <vector>

#include "firmware_bridge/host/orientation_source.hpp"

namespace glint::host {
namespace {

// The smallest driver: publishes what the test hands it, on the test's thread.
class ManualSource final : public OrientationSource {
public:
    ManualSource(recording::Clock& clock, SourceOptions options)
        : OrientationSource("manual:test", clock, options) {}
    void start() override { set_state(LinkState::Connecting); }
    void stop() override { set_state(LinkState::Stopped); }
    bool feed(std::int64_t t_ns, glm::dquat q) { return publish({t_ns, q, 0}); }
    void disconnect() {
        set_state(LinkState::Disconnected);
        edit_health([](LinkHealth& h) { ++h.reconnects; });
        note_error("manual:test: gone");
    }
};

TEST(OrientationSource, AppliesTheLatencyOffsetToEverySample) {
    recording::VirtualClock clock(1'000'000);
    SourceOptions options;
    options.latency_offset_ns = 30'000'000;
    ManualSource source(clock, options);
    std::vector<OrientationSample> seen;
    source.set_sample_callback([&](const OrientationSample& s) { seen.push_back(s); });
    source.start();
    ASSERT_TRUE(source.feed(100'000'000, glm::dquat(1, 0, 0, 0)));
    ASSERT_EQ(seen.size(), 1u);
    EXPECT_EQ(seen[0].t_ns, 70'000'000);
    EXPECT_TRUE(source.orientation_at(70'000'000).world_from_sensor);
    EXPECT_FALSE(source.orientation_at(69'999'999).world_from_sensor);
}

TEST(OrientationSource, ReportsRateAgeAndAStallOncePerSilence) {
    recording::VirtualClock clock(0);
    SourceOptions options;
    options.stall_after_ns = 200'000'000;
    ManualSource source(clock, options);
    source.start();
    EXPECT_EQ(source.health().state, LinkState::Connecting);
    EXPECT_EQ(source.health().last_sample_age_ns, -1);
    for (int i = 0; i < 100; ++i) {  // 100 Hz for one second
        clock.advance_us(10'000);
        ASSERT_TRUE(source.feed(static_cast<std::int64_t>(clock.now_us()) * 1000, glm::dquat(1, 0, 0, 0)));
    }
    LinkHealth h = source.health();
    EXPECT_EQ(h.state, LinkState::Streaming);
    EXPECT_DOUBLE_EQ(h.rate_hz, 100.0);
    EXPECT_EQ(h.last_sample_age_ns, 0);
    EXPECT_EQ(h.samples, 100u);

    clock.advance_us(200'000);
    EXPECT_EQ(source.health().state, LinkState::Streaming);  // exactly at the limit: not yet
    clock.advance_us(1);
    h = source.health();
    EXPECT_EQ(h.state, LinkState::Stalled);
    EXPECT_EQ(h.stalls, 1u);
    EXPECT_EQ(source.health().stalls, 1u);  // one silence, one stall, however often it is read
    clock.advance_us(2'000'000);
    h = source.health();
    EXPECT_EQ(h.rate_hz, 0.0);
    EXPECT_EQ(h.stalls, 1u);

    ASSERT_TRUE(source.feed(static_cast<std::int64_t>(clock.now_us()) * 1000, glm::dquat(1, 0, 0, 0)));
    EXPECT_EQ(source.health().state, LinkState::Streaming);
    clock.advance_us(300'000);
    EXPECT_EQ(source.health().stalls, 2u);
}

TEST(OrientationSource, ADisconnectIsNotCountedAsAStall) {
    recording::VirtualClock clock(0);
    ManualSource source(clock, {});
    source.start();
    ASSERT_TRUE(source.feed(0, glm::dquat(1, 0, 0, 0)));
    source.disconnect();
    clock.advance_us(1'000'000);
    const LinkHealth h = source.health();
    EXPECT_EQ(h.state, LinkState::Disconnected);
    EXPECT_EQ(h.stalls, 0u);
    EXPECT_EQ(h.reconnects, 1u);
    EXPECT_EQ(h.last_error, "manual:test: gone");
}

TEST(OrientationSource, CountsAnOutOfOrderSampleAsAFrameError) {
    recording::VirtualClock clock(0);
    ManualSource source(clock, {});
    source.start();
    ASSERT_TRUE(source.feed(1000, glm::dquat(1, 0, 0, 0)));
    EXPECT_FALSE(source.feed(500, glm::dquat(1, 0, 0, 0)));
    const LinkHealth h = source.health();
    EXPECT_EQ(h.samples, 1u);
    EXPECT_EQ(h.frame_errors, 1u);
    EXPECT_NE(h.last_error.find("manual:test"), std::string::npos);
}

TEST(OrientationSource, RejectsANonPositiveStallLimit) {
    recording::VirtualClock clock(0);
    SourceOptions options;
    options.stall_after_ns = 0;
    EXPECT_THROW(ManualSource(clock, options), SourceError);
}

}  // namespace
}  // namespace glint::host
