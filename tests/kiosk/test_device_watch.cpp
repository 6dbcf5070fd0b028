// The kiosk's device rules (appliance/ui/device_watch.hpp) and the fault injection that tests them
// through the real program (appliance/ui/fault_injection.hpp).
#include <gtest/gtest.h>

#include "appliance/core/errors.hpp"
#include "appliance/ui/device_watch.hpp"
#include "appliance/ui/fault_injection.hpp"

namespace glint::ui {
namespace {

TEST(DeviceWatch, ASilentCameraIsRestartedAtOnceThenEveryStallPeriodUntilItDelivers) {
    DeviceWatch w({3.0, 0.5}, 0.0);
    double t = 0;
    for (; t < 5; t += 0.25) EXPECT_FALSE(w.update(t, 1, 10).restart_camera);
    // Silence from 5 s: lost after 3 s, restarted at once, then every 3 s.
    int restarts = 0;
    double first_restart = -1;
    for (; t < 14.9; t += 0.25) {
        const DeviceWatch::Step s = w.update(t, 0, 10);
        if (s.restart_camera) {
            ++restarts;
            if (first_restart < 0) first_restart = t;
            w.camera_restarted(t, restarts == 1 ? "no such camera" : "");
        }
    }
    EXPECT_TRUE(w.camera_lost());
    EXPECT_NEAR(first_restart, 8.0, 0.3);  // last frame at 4.75 s + 3 s
    EXPECT_EQ(restarts, 3);                // ~8, ~11, ~14
    EXPECT_EQ(w.counts().camera_restart_failures, 1u);
    EXPECT_EQ(w.counts().camera_restarts, 2u);
    const DeviceWatch::Step back = w.update(15.0, 1, 10);
    EXPECT_FALSE(w.camera_lost());
    ASSERT_EQ(back.log.size(), 1u);
    EXPECT_NE(back.log[0].find("frames again"), std::string::npos);
    EXPECT_NEAR(w.counts().camera_lost_s, 15.0 - 4.75, 1e-9);
    EXPECT_EQ(w.counts().camera_losses, 1u);
}

TEST(DeviceWatch, TheSensorIsLostAfterItsSilenceAndFoundWithItsNextSample) {
    DeviceWatch w({3.0, 0.5}, 0.0);
    w.update(0.0, 1, 5);
    EXPECT_FALSE(w.update(0.4, 1, 0).log.size());
    EXPECT_FALSE(w.sensor_lost());
    EXPECT_EQ(w.update(0.6, 1, 0).log.size(), 1u);
    EXPECT_TRUE(w.sensor_lost());
    w.update(2.0, 1, 0);
    EXPECT_TRUE(w.sensor_lost());
    w.update(2.1, 1, 3);
    EXPECT_FALSE(w.sensor_lost());
    EXPECT_NEAR(w.counts().sensor_lost_s, 2.1, 1e-9);
    EXPECT_EQ(w.counts().sensor_losses, 1u);
}

TEST(DeviceWatch, FramesOutOfOrderOrRepeatedAreDroppedAndCounted) {
    DeviceWatch w;
    EXPECT_TRUE(w.accept_frame(100));
    EXPECT_TRUE(w.accept_frame(200));
    EXPECT_FALSE(w.accept_frame(150));
    EXPECT_FALSE(w.accept_frame(200));
    EXPECT_TRUE(w.accept_frame(300));
    EXPECT_EQ(w.counts().frames_out_of_order, 2u);
    const DeviceWatch::Step s = w.update(0.1, 3, 1);
    ASSERT_EQ(s.log.size(), 1u);
    EXPECT_NE(s.log[0].find("2 frame(s) out of order"), std::string::npos);
    EXPECT_TRUE(w.update(0.2, 1, 1).log.empty());  // not again until the 20th
}

TEST(DeviceWatch, RatesCountTheLastSecond) {
    DeviceWatch w;
    for (int k = 0; k < 60; ++k) w.update(k / 30.0, 1, 7);  // 30 fps, 210 samples a second
    EXPECT_NEAR(w.camera_fps(), 30, 1);
    EXPECT_NEAR(w.sensor_rate_hz(), 210, 7);
}

TEST(FaultPlan, ParsesEveryKindAndNamesWhatIsWrong) {
    const FaultPlan p =
        parse_fault_plan("sensor-gap:4:6,camera-stall:10:14.5,camera-shuffle:3:4,camera-mode:8:9,loop-stall:3:2,gl-lost:7");
    ASSERT_EQ(p.camera_modes.size(), 1u);
    EXPECT_TRUE(p.camera_modes[0].contains(8.5));
    EXPECT_FALSE(parse_fault_plan("camera-mode:8:9").empty());
    ASSERT_EQ(p.sensor_gaps.size(), 1u);
    EXPECT_DOUBLE_EQ(p.sensor_gaps[0].from_s, 4);
    EXPECT_TRUE(p.sensor_gaps[0].contains(5.9));
    EXPECT_FALSE(p.sensor_gaps[0].contains(6.0));
    ASSERT_EQ(p.camera_stalls.size(), 1u);
    EXPECT_DOUBLE_EQ(p.camera_stalls[0].to_s, 14.5);
    ASSERT_TRUE(p.loop_stall);
    EXPECT_DOUBLE_EQ(p.loop_stall->to_s, 5);
    ASSERT_TRUE(p.gl_lost_at_s);
    EXPECT_DOUBLE_EQ(*p.gl_lost_at_s, 7);
    EXPECT_TRUE(parse_fault_plan("").empty());
    for (const char* bad : {"sensor-gap:6:4", "sensor-gap:4", "camera-stall:a:5", "melt:1", "loop-stall:1:0",
                            "gl-lost:-1", "camera-mode:9:8"}) {
        try {
            parse_fault_plan(bad, "--inject-fault");
            ADD_FAILURE() << bad << " was accepted";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("--inject-fault"), std::string::npos) << e.what();
        }
    }
}

// A source that delivers what the test puts in it.
class ScriptedSource final : public KioskSource {
public:
    KioskPoll next;
    capture::CameraCalibration cal;
    render::CameraResponse resp;
    std::string describe() const override { return "scripted"; }
    const capture::CameraCalibration& calibration() const override { return cal; }
    const render::CameraResponse& response() const override { return resp; }
    void configure_capture(capture::CaptureOptions&) override {}
    std::int64_t start_ns() const override { return 1'000'000'000; }
    KioskPoll poll(std::int64_t) override { return std::move(next); }
    std::optional<glm::dquat> world_from_sensor(std::int64_t) const override { return glm::dquat(1, 0, 0, 0); }
    bool ended(std::int64_t) const override { return false; }
};

capture::CameraFrame frame_at(std::int64_t t_ns) {
    capture::CameraFrame f;
    f.t_ns = t_ns;
    return f;
}

TEST(FaultInjectingSource, WithholdsWhatTheWindowsSayAndSwapsPairs) {
    ScriptedSource inner;
    FaultInjectingSource faulty(inner, parse_fault_plan("sensor-gap:1:2,camera-stall:3:4,camera-shuffle:5:6"), {});
    const std::int64_t t0 = inner.start_ns();
    const auto at = [&](double s) { return t0 + std::int64_t(s * 1e9); };
    // Sensor gap: samples and lookups inside it are gone.
    inner.next.orientations = {{at(0.9), glm::dquat(1, 0, 0, 0)}, {at(1.5), glm::dquat(1, 0, 0, 0)}};
    EXPECT_EQ(faulty.poll(at(1.5)).orientations.size(), 1u);
    EXPECT_FALSE(faulty.world_from_sensor(at(1.5)));
    EXPECT_TRUE(faulty.world_from_sensor(at(2.5)));
    // Camera stall: no frames.
    inner.next.frames = {frame_at(at(3.4))};
    EXPECT_TRUE(faulty.poll(at(3.5)).frames.empty());
    // Shuffle: a, b come out as b, a.
    inner.next.frames = {frame_at(at(5.1)), frame_at(at(5.2))};
    const KioskPoll p = faulty.poll(at(5.2));
    ASSERT_EQ(p.frames.size(), 2u);
    EXPECT_EQ(p.frames[0].t_ns, at(5.2));
    EXPECT_EQ(p.frames[1].t_ns, at(5.1));
}

}  // namespace
}  // namespace glint::ui
