// The sensor board's main loop: samples the IMU on a fixed schedule, sends Orientation,
// RawImu, FusionStatus, Heartbeat, ButtonEvent and ErrorReport frames, answers HelloRequest,
// ConfigGet and ConfigSet, and drives the status lamp. Portable: it sees the board only through
// the HAL (hal.hpp) and the IMU only through ImuSource; no heap, no exceptions.
//
//   Firmware fw(hal, imu, info);
//   fw.start();                                   // idle delimiter + Hello with seq 0
//   for (;;) { fw.poll(); hal.clock.wait_until_us(fw.next_wake_us()); }
#pragma once

#include <array>
#include <cstdint>

#include "firmware_bridge/firmware/button_debouncer.hpp"
#include "firmware_bridge/firmware/hal.hpp"
#include "firmware_bridge/firmware/imu_source.hpp"
#include "firmware_bridge/protocol/frame.hpp"
#include "firmware_bridge/protocol/frame_decoder.hpp"

namespace glint::firmware {

inline constexpr std::uint8_t kFirmwareMajor = 1;
inline constexpr std::uint8_t kFirmwareMinor = 0;
inline constexpr std::uint16_t kFirmwarePatch = 0;
inline constexpr std::uint8_t kMaxButtons = 4;

// Configuration keys of this board beyond PROTOCOL.md's v1.0 list (keys are an open set; an
// appliance that does not know them never sends them).
namespace board_key {
inline constexpr std::uint16_t kSampleRateHz = 0x0100;  // U32, IMU samples per second, 100..1000
inline constexpr std::uint16_t kFusionKp = 0x0101;      // F32, Mahony proportional gain (raw IMU)
inline constexpr std::uint16_t kFusionKi = 0x0102;      // F32, Mahony integral gain (raw IMU)
}  // namespace board_key

struct BoardInfo {
    std::uint32_t board_id = 0;
    std::uint8_t button_count = 1;  // <= kMaxButtons
};

struct FirmwareSettings {
    std::uint32_t sample_rate_hz = 200;       // IMU reads per second (>= 100)
    std::uint32_t orientation_rate_hz = 100;  // 0 = off, <= sample rate
    std::uint32_t raw_rate_hz = 0;            // 0 = off, <= sample rate
    std::uint32_t heartbeat_period_ms = 1000; // 0 = off
    std::uint32_t button_debounce_ms = 20;
};

inline constexpr std::uint32_t kMinSampleRateHz = 100;
inline constexpr std::uint32_t kMaxSampleRateHz = 1000;
inline constexpr std::uint64_t kFusionStatusPeriodUs = 1'000'000;
inline constexpr std::uint64_t kErrorRepeatUs = 1'000'000;   // a lasting fault is re-reported
inline constexpr std::uint64_t kLampBlinkHalfPeriodUs = 250'000;

// Counters kept by the firmware (the link ones also go out in every Heartbeat).
struct FirmwareStats {
    std::uint32_t frames_sent = 0;
    std::uint32_t frames_dropped = 0;
    std::uint32_t rx_frames_ok = 0;
    std::uint32_t rx_frames_bad = 0;
    std::uint32_t samples = 0;        // IMU samples read successfully
    std::uint32_t sensor_faults = 0;  // failed IMU polls
};

// Times of a fixed-rate event: event k is due at start + ceil(k * 1e6 / rate) us, so any rate
// (e.g. 3 Hz) keeps its long-term average exactly, without accumulating rounding.
class RateSchedule {
public:
    void restart(std::uint64_t start_us, std::uint32_t rate_hz) {
        start_us_ = start_us;
        rate_hz_ = rate_hz;
        count_ = 0;
    }
    bool enabled() const { return rate_hz_ != 0; }
    std::uint64_t next_due_us() const {
        if (rate_hz_ == 0) return UINT64_MAX;
        return start_us_ + (count_ * 1'000'000 + rate_hz_ - 1) / rate_hz_;
    }
    // True when an event is due at `now_us`; advances past every missed slot (a late loop
    // sends one event, never a burst of catch-up events).
    bool take(std::uint64_t now_us) {
        if (now_us < next_due_us()) return false;
        while (next_due_us() <= now_us) ++count_;
        return true;
    }

private:
    std::uint64_t start_us_ = 0;
    std::uint32_t rate_hz_ = 0;
    std::uint64_t count_ = 0;
};

// Rate limit of an ErrorReport kind: the first report at once, then at most one per
// kErrorRepeatUs, so a lasting fault or a babbling line cannot flood the link.
class ErrorReportLimit {
public:
    // True when a report may go out at `now_us` (it then counts as sent); `new_episode` lets it
    // through regardless, for the first failure after a good spell.
    bool allow(std::uint64_t now_us, bool new_episode = false) {
        if (!new_episode && reported_ && now_us - last_us_ < kErrorRepeatUs) return false;
        reported_ = true;
        last_us_ = now_us;
        return true;
    }

private:
    bool reported_ = false;
    std::uint64_t last_us_ = 0;
};

class Firmware {
public:
    Firmware(const Hal& hal, ImuSource& imu, BoardInfo info, FirmwareSettings settings = {});

    // After reset: an idle delimiter (ends any partial frame at the receiver) and Hello (seq 0).
    void start();
    // One pass of the main loop: receive and answer requests, read the buttons, sample the IMU
    // when due, send whatever is due. Never blocks.
    void poll();
    // The board clock time at which poll() has something to do next.
    std::uint64_t next_wake_us() const;

    const FirmwareStats& stats() const { return stats_; }
    const FirmwareSettings& settings() const { return settings_; }
    bool lamp_on() const { return lamp_on_; }

private:
    bool send(const protocol::Message& message);
    void send_hello();
    bool send_error(protocol::ErrorCode code, std::uint32_t detail, std::uint64_t now_us);
    void receive(std::uint64_t now_us);
    void handle(const protocol::FrameEvent& event, std::uint64_t now_us);
    protocol::ConfigAck configure(std::uint16_t key, const protocol::ConfigValue* new_value);
    void read_buttons(std::uint64_t now_us);
    void sample(std::uint64_t now_us);
    void report_sensor_fault(ImuStatus status, std::uint64_t now_us);
    void send_fusion_status(std::uint64_t now_us);
    void update_lamp(std::uint64_t now_us);
    void restart_schedules(std::uint64_t now_us);

    Hal hal_;
    ImuSource& imu_;
    BoardInfo info_;
    FirmwareSettings settings_;
    protocol::FrameWriter writer_;
    protocol::FrameDecoder decoder_;
    std::array<std::uint8_t, protocol::kMaxFrameSize> tx_{};
    FirmwareStats stats_;
    std::uint64_t start_us_ = 0;

    RateSchedule sample_schedule_;
    RateSchedule orientation_schedule_;
    RateSchedule raw_schedule_;
    std::uint64_t next_heartbeat_us_ = 0;
    std::uint64_t next_fusion_status_us_ = 0;

    ImuReading reading_{};
    bool have_reading_ = false;
    CalibrationLevels last_sent_calibration_{};
    protocol::FusionMode last_sent_mode_ = protocol::FusionMode::Off;

    ImuStatus last_imu_status_ = ImuStatus::Starting;
    ErrorReportLimit sensor_error_limit_;
    ErrorReportLimit rx_error_limit_;
    std::uint32_t drops_unreported_ = 0;

    std::array<ButtonDebouncer, kMaxButtons> buttons_{};
    bool lamp_on_ = false;
};

}  // namespace glint::firmware
