// The firmware main loop on a simulated board (virtual clock, UART in memory), its output
// decoded with the protocol's FrameDecoder: message types, rates, sequence numbers, Hello on
// start and on request, ConfigGet/ConfigSet/ConfigAck round trips, debounced buttons, error
// reports for sensor faults and transmit overflow, and the orientation against the truth.
#include <gtest/gtest.h>

#include <array>
#include <map>

#include "firmware_bridge/firmware/sim/sim_board.hpp"
#include "firmware_test_support.hpp"

namespace glint::firmware {
namespace {

namespace p = protocol;
using test::angle_deg;

struct LoopRig {
    explicit LoopRig(sim::SimBoardOptions options, const std::string& trajectory_name = "static")
        : trajectory(sim::Trajectory::builtin(trajectory_name)), board(this->trajectory, std::move(options), uart, clock) {}

    // Runs the board to `end_us` and returns the frames it sent meanwhile.
    std::vector<p::FrameEvent> run_until(std::uint64_t end_us) {
        board.run_until(end_us);
        const std::vector<std::uint8_t> bytes = uart.take();
        return test::decode_all(decoder, bytes);
    }
    // Sends a message from the "appliance" (its own sequence numbers).
    void send(const p::Message& m) {
        std::array<std::uint8_t, p::kMaxFrameSize> buf{};
        const p::EncodeResult r = host_writer.write(m, buf);
        ASSERT_EQ(r.status, p::EncodeStatus::Ok);
        uart.inject(std::span<const std::uint8_t>(buf.data(), r.size));
    }

    sim::Trajectory trajectory;
    sim::VirtualClock clock;
    sim::MemoryUart uart;
    sim::SimBoard board;
    p::FrameDecoder decoder;
    p::FrameWriter host_writer;
};

std::map<p::MessageType, int> count_types(const std::vector<p::FrameEvent>& events) {
    std::map<p::MessageType, int> counts;
    for (const auto& e : events) {
        if (e.status == p::FrameStatus::Ok) ++counts[e.message.type];
    }
    return counts;
}

const p::FrameEvent* find_type(const std::vector<p::FrameEvent>& events, p::MessageType type) {
    for (const auto& e : events) {
        if (e.status == p::FrameStatus::Ok && e.message.type == type) return &e;
    }
    return nullptr;
}

class FirmwareLoop : public testing::TestWithParam<sim::ImuKind> {};

TEST_P(FirmwareLoop, StreamsAtTheConfiguredRatesWithConsecutiveSequenceNumbers) {
    sim::SimBoardOptions options;
    options.imu = GetParam();
    options.settings.raw_rate_hz = 50;
    LoopRig rig(options);
    rig.board.start();
    const auto events = rig.run_until(10'000'000);
    ASSERT_FALSE(events.empty());
    // Hello first, with seq 0; then every frame Ok and in sequence.
    ASSERT_EQ(events[0].status, p::FrameStatus::Ok);
    EXPECT_EQ(events[0].message.type, p::MessageType::Hello);
    EXPECT_EQ(events[0].seq, 0);
    for (std::size_t i = 0; i < events.size(); ++i) {
        ASSERT_EQ(events[i].status, p::FrameStatus::Ok) << "frame " << i;
        ASSERT_EQ(events[i].seq, static_cast<std::uint16_t>(i)) << "frame " << i;
    }
    EXPECT_EQ(rig.decoder.stats().lost_frames, 0u);
    const auto& hello = events[0].message.hello;
    EXPECT_EQ(hello.board_id, options.info.board_id);
    EXPECT_EQ(hello.capabilities & 0x3F, 0x3Fu);  // gyro, accel, mag, fusion, raw, buttons
    EXPECT_EQ(hello.button_count, 1);

    auto counts = count_types(events);
    // 100 Hz orientation over ~10 s, less the start-up (BNO055 boot 0.65 s, MPU reset 0.1 s).
    EXPECT_GE(counts[p::MessageType::Orientation], 920);
    EXPECT_LE(counts[p::MessageType::Orientation], 1001);
    EXPECT_GE(counts[p::MessageType::RawImu], 460);
    EXPECT_LE(counts[p::MessageType::RawImu], 501);
    EXPECT_GE(counts[p::MessageType::FusionStatus], 10);  // 1 Hz plus calibration changes
    // ... and not a status at every sample (the raw IMU's field arrives every other sample:
    // its verdict stands between samples).
    EXPECT_LE(counts[p::MessageType::FusionStatus], 30);
    EXPECT_EQ(counts[p::MessageType::Heartbeat], 9);  // at 1 .. 9 s; the run ends as 10 s arrives
    EXPECT_EQ(counts[p::MessageType::ErrorReport], 0);

    // Orientation timestamps 10 ms apart; the estimate matches the truth.
    std::uint64_t previous = 0;
    double worst = 0;
    for (const auto& e : events) {
        if (e.message.type != p::MessageType::Orientation) continue;
        const p::Orientation& o = e.message.orientation;
        if (previous != 0) {
            EXPECT_EQ(o.timestamp_us - previous, 10'000u);
        }
        previous = o.timestamp_us;
        EXPECT_GE(o.w_q30, 0);
        if (o.timestamp_us > 3'000'000) {
            worst = std::max(worst, angle_deg(test::quat_from_orientation(o),
                                              rig.trajectory.at(o.timestamp_us).world_from_sensor));
        }
    }
    EXPECT_LT(worst, 1.0);
    // Heartbeats count what was sent before them.
    const p::FrameEvent* hb = find_type(events, p::MessageType::Heartbeat);
    ASSERT_NE(hb, nullptr);
    EXPECT_EQ(hb->message.heartbeat.frames_sent, hb->seq);
    EXPECT_EQ(hb->message.heartbeat.uptime_s, 1u);
}

TEST_P(FirmwareLoop, ConfigSetGetAndAckRoundTrip) {
    sim::SimBoardOptions options;
    options.imu = GetParam();
    LoopRig rig(options);
    rig.board.start();
    rig.run_until(2'000'000);

    rig.send(p::ConfigSet{static_cast<std::uint16_t>(p::ConfigKey::OrientationRateHz), p::ConfigValue::from_u32(25)});
    rig.send(p::ConfigGet{static_cast<std::uint16_t>(p::ConfigKey::BoardId)});
    rig.send(p::ConfigSet{static_cast<std::uint16_t>(p::ConfigKey::BoardId), p::ConfigValue::from_u32(7)});
    rig.send(p::ConfigSet{static_cast<std::uint16_t>(p::ConfigKey::RawImuRateHz), p::ConfigValue::from_u32(5000)});
    rig.send(p::ConfigSet{static_cast<std::uint16_t>(p::ConfigKey::HeartbeatPeriodMs), p::ConfigValue::from_bool(true)});
    rig.send(p::ConfigGet{0x7777});
    rig.send(p::ConfigSet{board_key::kSampleRateHz, p::ConfigValue::from_u32(100)});
    rig.send(p::ConfigSet{board_key::kFusionKp, p::ConfigValue::from_f32(2.5f)});
    const auto events = rig.run_until(4'000'000);

    std::vector<p::ConfigAck> acks;
    for (const auto& e : events) {
        if (e.message.type == p::MessageType::ConfigAck) acks.push_back(e.message.config_ack);
    }
    ASSERT_EQ(acks.size(), 8u);
    for (std::size_t i = 0; i < acks.size(); ++i) EXPECT_EQ(acks[i].request_seq, i) << i;
    EXPECT_EQ(acks[0].status, p::ConfigStatus::Ok);
    EXPECT_EQ(acks[0].value, p::ConfigValue::from_u32(25));
    EXPECT_EQ(acks[1].status, p::ConfigStatus::Ok);
    EXPECT_EQ(acks[1].value, p::ConfigValue::from_u32(options.info.board_id));
    EXPECT_EQ(acks[2].status, p::ConfigStatus::ReadOnly);
    EXPECT_EQ(acks[2].value, p::ConfigValue::from_u32(options.info.board_id));
    EXPECT_EQ(acks[3].status, p::ConfigStatus::BadValue);  // above the sample rate
    EXPECT_EQ(acks[3].value, p::ConfigValue::from_u32(0));
    EXPECT_EQ(acks[4].status, p::ConfigStatus::BadValue);  // wrong type
    EXPECT_EQ(acks[4].value, p::ConfigValue::from_u32(1000));
    EXPECT_EQ(acks[5].status, p::ConfigStatus::UnknownKey);
    EXPECT_EQ(acks[6].status, p::ConfigStatus::Ok);
    EXPECT_EQ(acks[6].value, p::ConfigValue::from_u32(100));
    if (GetParam() == sim::ImuKind::Raw) {
        EXPECT_EQ(acks[7].status, p::ConfigStatus::Ok);
        EXPECT_EQ(acks[7].value, p::ConfigValue::from_f32(2.5f));
    } else {
        EXPECT_EQ(acks[7].status, p::ConfigStatus::UnknownKey);  // the BNO055 fuses on its own
    }
    EXPECT_EQ(rig.board.firmware().stats().rx_frames_ok, 8u);

    // The new orientation rate holds: 25 frames per second.
    const auto later = rig.run_until(6'000'000);
    EXPECT_EQ(count_types(later)[p::MessageType::Orientation], 50);
}

TEST_P(FirmwareLoop, AnswersHelloRequestWithTheRunningSequenceNumber) {
    sim::SimBoardOptions options;
    options.imu = GetParam();
    LoopRig rig(options);
    rig.board.start();
    rig.run_until(1'000'000);
    rig.send(p::HelloRequest{});
    const auto events = rig.run_until(1'100'000);
    const p::FrameEvent* hello = find_type(events, p::MessageType::Hello);
    ASSERT_NE(hello, nullptr);
    EXPECT_GT(hello->seq, 0);
    // A Hello on request is an ordinary frame: no restart, no loss.
    EXPECT_EQ(rig.decoder.stats().sender_restarts, 0u);
    EXPECT_EQ(rig.decoder.stats().lost_frames, 0u);
}

TEST_P(FirmwareLoop, ReportsSensorFaultsAndRecovers) {
    sim::SimBoardOptions options;
    options.imu = GetParam();
    options.imu_nacks.push_back({3'000'000, 5'500'000});
    LoopRig rig(options);
    rig.board.start();
    const auto events = rig.run_until(8'000'000);
    std::vector<p::ErrorReport> errors;
    std::uint64_t last_orientation_in_fault = 0, first_after = 0;
    for (const auto& e : events) {
        if (e.message.type == p::MessageType::ErrorReport) errors.push_back(e.message.error_report);
        if (e.message.type == p::MessageType::Orientation) {
            const std::uint64_t t = e.message.orientation.timestamp_us;
            if (t >= 3'000'000 && t < 5'500'000) last_orientation_in_fault = t;
            if (t >= 5'500'000 && first_after == 0) first_after = t;
        }
    }
    // The first failure is a read failure, then "not responding" once a second while it lasts.
    ASSERT_GE(errors.size(), 3u);
    EXPECT_EQ(errors[0].code, static_cast<std::uint16_t>(p::ErrorCode::SensorReadFailed));
    EXPECT_EQ(errors[0].detail & (p::capability::kGyro | p::capability::kAccel), p::capability::kGyro | p::capability::kAccel);
    EXPECT_GE(errors[0].timestamp_us, 3'000'000u);
    EXPECT_LT(errors[0].timestamp_us, 3'010'000u);
    EXPECT_EQ(errors[1].code, static_cast<std::uint16_t>(p::ErrorCode::SensorNotResponding));
    EXPECT_LE(errors.size(), 5u);  // rate-limited
    EXPECT_EQ(last_orientation_in_fault, 0u);  // nothing stale sent during the fault
    ASSERT_NE(first_after, 0u);
    EXPECT_LT(first_after, 6'000'000u);  // back within 0.5 s of the bus recovering
    EXPECT_TRUE(rig.board.gpio().lamp());
    EXPECT_GT(rig.board.gpio().lamp_changes(), 3u);  // blinked during the fault
}

INSTANTIATE_TEST_SUITE_P(Imus, FirmwareLoop, testing::Values(sim::ImuKind::Bno055, sim::ImuKind::Raw),
                         [](const testing::TestParamInfo<sim::ImuKind>& param) {
                             return param.param == sim::ImuKind::Bno055 ? "Bno055" : "Raw";
                         });

TEST(FirmwareButtons, OneEventPerDebouncedEdgeDespiteBounce) {
    sim::SimBoardOptions options;
    options.presses.push_back({0, 2'000'000, 2'500'000, 4000});
    options.presses.push_back({0, 3'000'000, 3'010'000, 0});  // 10 ms: shorter than the debounce
    LoopRig rig(options);
    rig.board.start();
    const auto events = rig.run_until(4'000'000);
    std::vector<p::ButtonEvent> buttons;
    for (const auto& e : events) {
        if (e.message.type == p::MessageType::ButtonEvent) buttons.push_back(e.message.button_event);
    }
    ASSERT_EQ(buttons.size(), 2u);
    EXPECT_EQ(buttons[0].state, p::ButtonState::Pressed);
    EXPECT_EQ(buttons[1].state, p::ButtonState::Released);
    EXPECT_EQ(buttons[0].button_id, 0);
    // Timestamp: when the settled level was first read (within one 5 ms loop of the bounce end).
    EXPECT_GE(buttons[0].timestamp_us, 2'000'000u);
    EXPECT_LE(buttons[0].timestamp_us, 2'010'000u);
    EXPECT_GE(buttons[1].timestamp_us, 2'500'000u);
    EXPECT_LE(buttons[1].timestamp_us, 2'510'000u);
}

TEST(FirmwareTransmit, DroppedFramesAreCountedAndReported) {
    sim::SimBoardOptions options;
    LoopRig rig(options);
    rig.board.start();
    rig.run_until(2'000'000);
    // The link stalls: nothing fits for 100 ms.
    rig.uart.set_capacity(0);
    rig.board.run_until(2'100'000);
    rig.uart.set_capacity(SIZE_MAX);
    const auto events = rig.run_until(2'200'000);
    const std::uint32_t dropped = rig.board.firmware().stats().frames_dropped;
    EXPECT_GE(dropped, 10u);  // 100 Hz orientation for 100 ms
    const p::FrameEvent* report = find_type(events, p::MessageType::ErrorReport);
    ASSERT_NE(report, nullptr);
    EXPECT_EQ(report->message.error_report.code, static_cast<std::uint16_t>(p::ErrorCode::TransmitOverflow));
    EXPECT_EQ(report->message.error_report.detail, dropped);
    // A dropped frame had its sequence number: the receiver sees exactly the drops as lost.
    EXPECT_EQ(rig.decoder.stats().lost_frames, dropped);
}

TEST(FirmwareReceive, BadFramesAreCountedAndReportedOnce) {
    sim::SimBoardOptions options;
    LoopRig rig(options);
    rig.board.start();
    rig.run_until(1'000'000);
    const std::array<std::uint8_t, 6> garbage{0x05, 0x11, 0x22, 0x33, 0x44, 0x00};
    rig.uart.inject(garbage);
    rig.uart.inject(garbage);
    const auto events = rig.run_until(1'100'000);
    EXPECT_EQ(rig.board.firmware().stats().rx_frames_bad, 2u);
    int reports = 0;
    for (const auto& e : events) {
        if (e.message.type == p::MessageType::ErrorReport) {
            ++reports;
            EXPECT_EQ(e.message.error_report.code, static_cast<std::uint16_t>(p::ErrorCode::ReceivedBadFrame));
        }
    }
    EXPECT_EQ(reports, 1);  // one per second at most
}

}  // namespace
}  // namespace glint::firmware
