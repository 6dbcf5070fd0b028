// Deterministic synthetic session: board schedule -> serial line timing -> appliance reads ->
// Recorder + live FrameDecoder, in that order, as in a real capture.
#include "firmware_bridge/recording/session_generator.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
#include <random>
#include <vector>

#include "firmware_bridge/firmware/rotation.hpp"
#include "firmware_bridge/protocol/frame.hpp"
#include "firmware_bridge/protocol/frame_decoder.hpp"
#include "firmware_bridge/recording/recorder.hpp"

namespace glint::recording {
namespace {

namespace proto = glint::protocol;

// Board clock (µs since the board's reset) at which the session starts: the board booted 0.3 s
// before its Hello.
constexpr std::uint64_t kBoardStartUs = 300'000;
// Appliance CLOCK_MONOTONIC minus board clock (the two clocks are unrelated; 2 h of uptime).
constexpr std::uint64_t kBoardToHostUs = 7'200'000'000;
// Time the firmware takes from the measurement to the first byte on the line.
constexpr std::uint64_t kFirmwareLatencyUs = 200;
// Fixed creation time (2025-01-01T00:00:00Z) so that the file is reproducible.
constexpr std::int64_t kCreatedUnixUs = 1'735'689'600'000'000;

constexpr double kYawRateRadS = 45.0 * std::numbers::pi / 180.0;   // about world +Y
constexpr double kPitchAmplitudeRad = 10.0 * std::numbers::pi / 180.0;
constexpr double kPitchFrequencyHz = 0.5;
constexpr double kGravityMS2 = 9.80665;

// Pseudo-random numbers from the engine's raw output (fixed by the standard); the standard
// distributions are implementation-defined and would make the file differ between libraries.
class Random {
public:
    explicit Random(std::uint64_t seed) : engine_(seed) {}
    std::uint64_t below(std::uint64_t n) { return engine_() % n; }            // [0, n), n > 0
    double unit() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
    std::uint8_t byte() { return static_cast<std::uint8_t>(engine_() >> 56); }

private:
    std::mt19937_64 engine_;
};

// Sensor-to-world rotation at time t_s (seconds since the session start): yaw about world +Y at
// a constant rate, then a pitch about the sensor's +X swinging sinusoidally.
firmware::Quatd orientation_at(double t_s) {
    const double yaw = kYawRateRadS * t_s;
    const double pitch = kPitchAmplitudeRad * std::sin(2.0 * std::numbers::pi * kPitchFrequencyHz * t_s);
    const firmware::Quatd q_yaw{std::cos(yaw / 2), 0, std::sin(yaw / 2), 0};
    const firmware::Quatd q_pitch{std::cos(pitch / 2), std::sin(pitch / 2), 0, 0};
    const firmware::Quatd q = q_yaw * q_pitch;
    // PROTOCOL.md: senders send w >= 0.
    return q.w < 0 ? firmware::Quatd{-q.w, -q.x, -q.y, -q.z} : q;
}

// World vector in sensor coordinates: conj(q) * v * q.
std::array<double, 3> to_sensor(const firmware::Quatd& q, std::array<double, 3> v) {
    const firmware::Quatd r = q.conj() * firmware::Quatd{0, v[0], v[1], v[2]} * q;
    return {r.x, r.y, r.z};
}

std::array<std::int32_t, 3> micro(const std::array<double, 3>& v, double scale) {
    std::array<std::int32_t, 3> out{};
    for (std::size_t i = 0; i < 3; ++i) out[i] = static_cast<std::int32_t>(std::lround(v[i] * scale));
    return out;
}

struct BoardMessage {
    std::uint64_t board_time_us;
    proto::Message message;
};

std::vector<BoardMessage> board_schedule(const SessionOptions& o) {
    std::vector<BoardMessage> out;
    const std::uint64_t end = kBoardStartUs + std::uint64_t{o.duration_ms} * 1000;
    out.push_back({kBoardStartUs,
                   proto::Hello{proto::kVersionMajor, proto::kVersionMinor, 1, 0, 0, 0x5EED0001u,
                                proto::capability::kGyro | proto::capability::kAccel | proto::capability::kMag |
                                    proto::capability::kOnBoardFusion | proto::capability::kRawImu |
                                    proto::capability::kButtons,
                                2}});
    for (std::uint64_t t = kBoardStartUs + 50'000; t < end; t += 1'000'000) {
        const auto mag_calib = static_cast<std::uint8_t>(t < kBoardStartUs + 2'000'000 ? 2 : 3);
        out.push_back({t, proto::FusionStatus{t, proto::FusionMode::Ndof, 3, 3, 3, mag_calib, {-120, 45, 7}}});
    }
    for (std::uint64_t k = 1;; ++k) {
        const std::uint64_t t = kBoardStartUs + k * 1'000'000 / o.orientation_hz;
        if (t >= end) break;
        const firmware::Quatd q = orientation_at(static_cast<double>(t - kBoardStartUs) * 1e-6);
        out.push_back({t, proto::Orientation{t, proto::to_q30(q.w), proto::to_q30(q.x), proto::to_q30(q.y),
                                             proto::to_q30(q.z)}});
    }
    for (std::uint64_t k = 1;; ++k) {
        const std::uint64_t t = kBoardStartUs + k * 1'000'000 / o.raw_imu_hz + 3'000;  // offset from orientation
        if (t >= end) break;
        const double s = static_cast<double>(t - kBoardStartUs) * 1e-6;
        const firmware::Quatd q = orientation_at(s);
        const double pitch = kPitchAmplitudeRad * std::sin(2.0 * std::numbers::pi * kPitchFrequencyHz * s);
        const double pitch_rate = kPitchAmplitudeRad * 2.0 * std::numbers::pi * kPitchFrequencyHz *
                                  std::cos(2.0 * std::numbers::pi * kPitchFrequencyHz * s);
        // Angular velocity in the sensor frame: the pitch rate about sensor X plus the world yaw
        // rate seen from the pitched sensor.
        const std::array<double, 3> gyro{pitch_rate, kYawRateRadS * std::cos(pitch), -kYawRateRadS * std::sin(pitch)};
        const auto accel = to_sensor(q, {0, kGravityMS2, 0});
        const auto mag_ut = to_sensor(q, {0, -40.0, -20.0});  // north is -Z, dipping down
        out.push_back({t, proto::RawImu{t, micro(gyro, 1e6), micro(accel, 1e6), micro(mag_ut, 1e3),
                                        proto::raw_valid::kGyro | proto::raw_valid::kAccel | proto::raw_valid::kMag}});
    }
    for (std::uint64_t k = 1;; ++k) {
        const std::uint64_t t = kBoardStartUs + k * 1'000'000;
        if (t >= end) break;
        out.push_back({t, proto::Heartbeat{t, static_cast<std::uint32_t>(t / 1'000'000), 0, 0, 1, 0}});
    }
    const std::uint64_t press = kBoardStartUs + std::uint64_t{o.duration_ms} * 1000 / 2;
    if (press + 250'000 < end) {
        out.push_back({press, proto::ButtonEvent{press, 0, proto::ButtonState::Pressed}});
        out.push_back({press + 250'000, proto::ButtonEvent{press + 250'000, 0, proto::ButtonState::Released}});
    }
    // The answer to the appliance's ConfigSet (sent at kBoardStartUs + 100 ms board-equivalent).
    out.push_back({kBoardStartUs + 102'000,
                   proto::ConfigAck{0, static_cast<std::uint16_t>(proto::ConfigKey::OrientationRateHz),
                                    proto::ConfigStatus::Ok, proto::ConfigValue::from_u32(o.orientation_hz)}});
    std::stable_sort(out.begin(), out.end(),
                     [](const BoardMessage& a, const BoardMessage& b) { return a.board_time_us < b.board_time_us; });
    return out;
}

struct LineItem {
    std::uint64_t queued_us;  // host time at which the sender starts to send
    Bytes bytes;
};

// Something the appliance sees or does, in host time order.
struct HostEvent {
    enum class Kind { Received, Sent, Gpio, Marker } kind;
    std::uint64_t time_us;
    Bytes bytes;
    std::string text;
    std::uint32_t line = 0;
    Edge edge = Edge::Rising;
};

}  // namespace

SessionSummary generate_session(const std::string& path, const SessionOptions& o, bool overwrite) {
    if (o.orientation_hz == 0 || o.raw_imu_hz == 0 || o.baud == 0 || o.max_chunk == 0 || o.garbage_period_ms == 0)
        throw RecordingError("session generator: rates, baud, chunk size and garbage period must be > 0");
    Random random(o.seed);
    SessionSummary summary;

    // 1. Board frames and garbage bursts queued on the line.
    std::vector<LineItem> line;
    proto::FrameWriter writer;  // seq 0 after reset: the Hello goes first
    std::array<std::uint8_t, proto::kMaxFrameSize> frame{};
    std::uint32_t frames_sent = 0;
    for (BoardMessage& m : board_schedule(o)) {
        if (m.message.type == proto::MessageType::Heartbeat) m.message.heartbeat.frames_sent = frames_sent;
        const proto::EncodeResult r = writer.write(m.message, frame);
        if (r.status != proto::EncodeStatus::Ok)
            throw RecordingError(std::string("session generator: cannot encode: ") + proto::status_name(r.status));
        line.push_back({m.board_time_us + kBoardToHostUs + kFirmwareLatencyUs, Bytes(frame.begin(), frame.begin() + r.size)});
        ++frames_sent;
    }
    summary.frames_sent = frames_sent;
    const std::uint64_t start_host = kBoardStartUs + kBoardToHostUs;
    const std::uint64_t end_host = start_host + std::uint64_t{o.duration_ms} * 1000;
    for (std::uint64_t t = start_host + 150'000;;) {
        t += static_cast<std::uint64_t>(o.garbage_period_ms * 1000.0 * (0.5 + random.unit()));
        if (t >= end_host) break;
        Bytes burst(1 + random.below(24));
        for (auto& b : burst) b = random.byte();
        summary.garbage_bytes += burst.size();
        ++summary.garbage_bursts;
        line.push_back({t, std::move(burst)});
    }
    std::stable_sort(line.begin(), line.end(), [](const LineItem& a, const LineItem& b) { return a.queued_us < b.queued_us; });

    // 2. The serial line: one byte every 10 bit times, items back to back when they queue up.
    Bytes stream;
    std::vector<std::uint64_t> arrival;  // host time at which each byte has been received
    std::uint64_t line_free = 0;
    for (const LineItem& item : line) {
        const std::uint64_t start = std::max(item.queued_us, line_free);
        for (std::size_t k = 0; k < item.bytes.size(); ++k) {
            stream.push_back(item.bytes[k]);
            arrival.push_back(start + (k + 1) * 10'000'000ull / o.baud);
        }
        line_free = arrival.back();
    }

    // 3. The appliance's reads: random sizes, ending early where the line went quiet, each
    //    returned a little after its last byte arrived.
    std::vector<HostEvent> events;
    std::uint64_t last_read = 0;
    for (std::size_t i = 0; i < stream.size();) {
        std::size_t n = 1 + random.below(o.max_chunk);
        std::size_t end = i + 1;
        while (end < stream.size() && end - i < n && arrival[end] - arrival[end - 1] < 2'000) ++end;
        const std::uint64_t read_at = std::max(last_read, arrival[end - 1] + 50 + random.below(1'950));
        last_read = read_at;
        HostEvent e{HostEvent::Kind::Received, read_at, Bytes(stream.begin() + static_cast<std::ptrdiff_t>(i),
                                                              stream.begin() + static_cast<std::ptrdiff_t>(end)),
                    {}};
        events.push_back(std::move(e));
        i = end;
    }
    summary.chunks = events.size();

    // 4. What the appliance does itself: a ConfigSet, a foot-switch edge pair, markers.
    {
        proto::FrameWriter appliance_writer;
        const proto::EncodeResult r = appliance_writer.write(
            proto::ConfigSet{static_cast<std::uint16_t>(proto::ConfigKey::OrientationRateHz),
                             proto::ConfigValue::from_u32(o.orientation_hz)},
            frame);
        events.push_back({HostEvent::Kind::Sent, start_host + 100'000, Bytes(frame.begin(), frame.begin() + r.size), {}});
    }
    const std::uint64_t gpio_at = start_host + std::uint64_t{o.duration_ms} * 1000 * 3 / 8;
    events.push_back({HostEvent::Kind::Gpio, gpio_at, {}, "gpiochip0", 17, Edge::Rising});
    events.push_back({HostEvent::Kind::Gpio, gpio_at + 120'000, {}, "gpiochip0", 17, Edge::Falling});
    events.push_back({HostEvent::Kind::Marker, start_host - 1'000, {}, "capture started"});
    events.push_back({HostEvent::Kind::Marker, std::max(last_read, end_host) + 1'000, {}, "capture stopped"});
    std::stable_sort(events.begin(), events.end(),
                     [](const HostEvent& a, const HostEvent& b) { return a.time_us < b.time_us; });

    // 5. Record exactly as a host driver does: bytes first, then what the decoder made of them.
    RecorderOptions options;
    options.header.created_unix_us = kCreatedUnixUs;
    options.header.created_monotonic_us = events.front().time_us - 1'000;
    options.header.transport = Transport::Simulator;
    options.header.baud = o.baud;
    options.header.device = "synthetic";
    options.header.decoded_types = board_message_types();
    options.header.notes = {{"generator", "glint-recording generate"},
                            {"seed", std::to_string(o.seed)},
                            {"duration_ms", std::to_string(o.duration_ms)},
                            {"motion", "yaw 45 deg/s about +Y, pitch 10 deg at 0.5 Hz"},
                            {"garbage", "random bursts of 1..24 bytes every ~" + std::to_string(o.garbage_period_ms) + " ms"}};
    options.overwrite = overwrite;
    VirtualClock clock(options.header.created_monotonic_us);
    Recorder recorder(path, options, clock);
    auto decoder = std::make_unique<proto::FrameDecoder>();
    for (const HostEvent& e : events) {
        clock.sleep_until_us(e.time_us);
        switch (e.kind) {
        case HostEvent::Kind::Received:
            recorder.on_bytes(e.time_us, e.bytes);
            decoder->feed_all(e.bytes, [&](const proto::FrameEvent& fe) {
                if (fe.status == proto::FrameStatus::Ok) ++summary.decoded;
                recorder.on_sample(e.time_us, fe);
            });
            break;
        case HostEvent::Kind::Sent: recorder.on_bytes(e.time_us, e.bytes, Direction::Sent); break;
        case HostEvent::Kind::Gpio: recorder.on_gpio(e.time_us, e.line, e.edge, e.text); break;
        case HostEvent::Kind::Marker: recorder.mark(e.time_us, e.text); break;
        }
    }
    if (!recorder.close()) throw RecordingError(recorder.error());
    return summary;
}

}  // namespace glint::recording
