// Sensor-board main loop: see firmware.hpp.
#include "firmware_bridge/firmware/firmware.hpp"

#include <cmath>
#include <cstring>

namespace glint::firmware {

namespace p = protocol;

namespace {

// value * scale as an int32, saturating (and mapping NaN to 0) so a wild sensor value can never
// wrap around on the wire.
std::int32_t scaled_i32(float value, double scale) {
    const double scaled = static_cast<double>(value) * scale;
    if (!(scaled == scaled)) return 0;
    if (scaled >= 2147483647.0) return INT32_MAX;
    if (scaled <= -2147483648.0) return INT32_MIN;
    return static_cast<std::int32_t>(std::lround(scaled));
}

std::array<std::int32_t, 3> scaled_i32(Vec3f v, double scale) {
    return {scaled_i32(v.x, scale), scaled_i32(v.y, scale), scaled_i32(v.z, scale)};
}

constexpr double kMicro = 1e6;       // rad/s -> urad/s, m/s^2 -> um/s^2
constexpr double kNanoTesla = 1e3;   // uT -> nT

p::ConfigValue u32(std::uint32_t v) { return p::ConfigValue::from_u32(v); }

}  // namespace

Firmware::Firmware(const Hal& hal, ImuSource& imu, BoardInfo info, FirmwareSettings settings)
    : hal_(hal), imu_(imu), info_(info), settings_(settings) {
    if (info_.button_count > kMaxButtons) info_.button_count = kMaxButtons;
    if (settings_.sample_rate_hz < kMinSampleRateHz) settings_.sample_rate_hz = kMinSampleRateHz;
    if (settings_.sample_rate_hz > kMaxSampleRateHz) settings_.sample_rate_hz = kMaxSampleRateHz;
    if (settings_.orientation_rate_hz > settings_.sample_rate_hz) {
        settings_.orientation_rate_hz = settings_.sample_rate_hz;
    }
    if (settings_.raw_rate_hz > settings_.sample_rate_hz) settings_.raw_rate_hz = settings_.sample_rate_hz;
}

void Firmware::restart_schedules(std::uint64_t now_us) {
    sample_schedule_.restart(now_us, settings_.sample_rate_hz);
    orientation_schedule_.restart(now_us, settings_.orientation_rate_hz);
    raw_schedule_.restart(now_us, settings_.raw_rate_hz);
}

void Firmware::start() {
    const std::uint64_t now = hal_.clock.now_us();
    start_us_ = now;
    const std::uint8_t idle = p::kFrameDelimiter;
    hal_.uart.write({&idle, 1});
    send_hello();
    restart_schedules(now);
    next_heartbeat_us_ = settings_.heartbeat_period_ms == 0
                             ? UINT64_MAX
                             : now + std::uint64_t{settings_.heartbeat_period_ms} * 1000;
    next_fusion_status_us_ = now + kFusionStatusPeriodUs;
}

bool Firmware::send(const p::Message& message) {
    const p::EncodeResult r = writer_.write(message, tx_);
    if (r.status != p::EncodeStatus::Ok) {
        // Only an invalid message gets here (e.g. a quaternion the fusion made non-finite);
        // the frame is not sent and counts as dropped.
        ++stats_.frames_dropped;
        return false;
    }
    if (!hal_.uart.write({tx_.data(), r.size})) {
        ++stats_.frames_dropped;
        ++drops_unreported_;
        return false;
    }
    ++stats_.frames_sent;
    return true;
}

void Firmware::send_hello() {
    std::uint32_t caps = imu_.capabilities();
    if (info_.button_count > 0) caps |= p::capability::kButtons;
    send(p::Hello{p::kVersionMajor, p::kVersionMinor, kFirmwareMajor, kFirmwareMinor, kFirmwarePatch,
                  info_.board_id, caps, info_.button_count});
}

bool Firmware::send_error(p::ErrorCode code, std::uint32_t detail, std::uint64_t now_us) {
    return send(p::ErrorReport{now_us, static_cast<std::uint16_t>(code), detail});
}

void Firmware::poll() {
    const std::uint64_t now = hal_.clock.now_us();
    receive(now);
    read_buttons(now);
    if (sample_schedule_.take(now)) sample(now);

    if (now >= next_fusion_status_us_) {
        send_fusion_status(now);
    }
    if (now >= next_heartbeat_us_) {
        send(p::Heartbeat{now, static_cast<std::uint32_t>((now - start_us_) / 1'000'000),
                          stats_.frames_sent, stats_.frames_dropped, stats_.rx_frames_ok,
                          stats_.rx_frames_bad});
        next_heartbeat_us_ = now + std::uint64_t{settings_.heartbeat_period_ms} * 1000;
    }
    // Frames were dropped (receiver not reading, buffer full): say how many, once there is room.
    // A report that cannot be sent either is one more dropped frame, counted in the next one.
    if (drops_unreported_ > 0) {
        const std::uint32_t dropped = drops_unreported_;
        if (send_error(p::ErrorCode::TransmitOverflow, dropped, now)) drops_unreported_ -= dropped;
    }
    update_lamp(now);
}

std::uint64_t Firmware::next_wake_us() const {
    std::uint64_t t = sample_schedule_.next_due_us();
    if (next_heartbeat_us_ < t) t = next_heartbeat_us_;
    if (next_fusion_status_us_ < t) t = next_fusion_status_us_;
    return t;
}

void Firmware::receive(std::uint64_t now_us) {
    std::array<std::uint8_t, 64> chunk{};
    for (;;) {
        const std::size_t n = hal_.uart.read(chunk);
        if (n == 0) break;
        decoder_.feed_all(std::span<const std::uint8_t>(chunk.data(), n),
                          [&](const p::FrameEvent& e) { handle(e, now_us); });
    }
}

void Firmware::handle(const p::FrameEvent& event, std::uint64_t now_us) {
    if (event.status != p::FrameStatus::Ok) {
        ++stats_.rx_frames_bad;
        // One report per second at most: a babbling line must not flood the link back.
        if (rx_error_limit_.allow(now_us)) {
            if (event.status == p::FrameStatus::UnknownType) {
                send_error(p::ErrorCode::ReceivedUnknownType, event.type, now_us);
            } else if (event.status == p::FrameStatus::BadLength) {
                send_error(p::ErrorCode::ReceivedBadLength,
                           (std::uint32_t{event.type} << 16) | event.payload_size, now_us);
            } else {
                send_error(p::ErrorCode::ReceivedBadFrame, static_cast<std::uint32_t>(event.status),
                           now_us);
            }
        }
        return;
    }
    ++stats_.rx_frames_ok;
    const p::Message& m = event.message;
    switch (m.type) {
        case p::MessageType::HelloRequest:
            send_hello();
            break;
        case p::MessageType::ConfigGet: {
            p::ConfigAck ack = configure(m.config_get.key, nullptr);
            ack.request_seq = event.seq;
            send(ack);
            break;
        }
        case p::MessageType::ConfigSet: {
            p::ConfigAck ack = configure(m.config_set.key, &m.config_set.value);
            ack.request_seq = event.seq;
            send(ack);
            break;
        }
        default:
            break;  // board-to-appliance types (or an ErrorReport from the appliance): nothing to do
    }
}

// Reads (new_value == nullptr) or writes one configuration key; returns the answer without its
// request_seq. Every rejected write leaves the setting unchanged and returns its current value.
p::ConfigAck Firmware::configure(std::uint16_t key, const p::ConfigValue* v) {
    p::ConfigAck ack{0, key, p::ConfigStatus::Ok, u32(0)};
    const std::uint64_t now = hal_.clock.now_us();
    const auto is = [&](p::ValueType type) { return v->type == type; };
    const auto bad = [&](p::ConfigValue current) {
        ack.status = p::ConfigStatus::BadValue;
        ack.value = current;
        return ack;
    };
    switch (key) {
        case static_cast<std::uint16_t>(p::ConfigKey::OrientationRateHz):
        case static_cast<std::uint16_t>(p::ConfigKey::RawImuRateHz): {
            const bool orientation = key == static_cast<std::uint16_t>(p::ConfigKey::OrientationRateHz);
            std::uint32_t& rate = orientation ? settings_.orientation_rate_hz : settings_.raw_rate_hz;
            if (v != nullptr) {
                if (!is(p::ValueType::U32) || v->as_u32() > settings_.sample_rate_hz) return bad(u32(rate));
                rate = v->as_u32();
                (orientation ? orientation_schedule_ : raw_schedule_).restart(now, rate);
            }
            ack.value = u32(rate);
            return ack;
        }
        case static_cast<std::uint16_t>(p::ConfigKey::FusionModeKey): {
            const auto current = [&] { return u32(static_cast<std::uint32_t>(imu_.mode())); };
            if (v != nullptr) {
                if (!is(p::ValueType::U32) || v->as_u32() > 255 ||
                    !imu_.set_mode(static_cast<p::FusionMode>(v->as_u32()))) {
                    return bad(current());
                }
            }
            ack.value = current();
            return ack;
        }
        case static_cast<std::uint16_t>(p::ConfigKey::HeartbeatPeriodMs): {
            if (v != nullptr) {
                const std::uint32_t ms = v->as_u32();
                // 0 = off; otherwise 100 ms .. 60 s (the host's link timeout expects heartbeats).
                if (!is(p::ValueType::U32) || (ms != 0 && (ms < 100 || ms > 60'000))) {
                    return bad(u32(settings_.heartbeat_period_ms));
                }
                settings_.heartbeat_period_ms = ms;
                next_heartbeat_us_ = ms == 0 ? UINT64_MAX : now + std::uint64_t{ms} * 1000;
            }
            ack.value = u32(settings_.heartbeat_period_ms);
            return ack;
        }
        case static_cast<std::uint16_t>(p::ConfigKey::BoardId):
            ack.value = u32(info_.board_id);
            if (v != nullptr) ack.status = p::ConfigStatus::ReadOnly;
            return ack;
        case static_cast<std::uint16_t>(p::ConfigKey::MagEnabled): {
            const auto current = [&] { return p::ConfigValue::from_bool(imu_.mode() == p::FusionMode::Ndof); };
            if (v != nullptr) {
                if (!is(p::ValueType::Bool)) return bad(current());
                // The magnetometer is what separates Ndof from Imu; with fusion off it is unused.
                if (imu_.mode() != p::FusionMode::Off &&
                    !imu_.set_mode(v->as_bool() ? p::FusionMode::Ndof : p::FusionMode::Imu)) {
                    return bad(current());
                }
            }
            ack.value = current();
            return ack;
        }
        case static_cast<std::uint16_t>(p::ConfigKey::ButtonDebounceMs): {
            if (v != nullptr) {
                if (!is(p::ValueType::U32) || v->as_u32() < 1 || v->as_u32() > 500) {
                    return bad(u32(settings_.button_debounce_ms));
                }
                settings_.button_debounce_ms = v->as_u32();
            }
            ack.value = u32(settings_.button_debounce_ms);
            return ack;
        }
        case board_key::kSampleRateHz: {
            if (v != nullptr) {
                const std::uint32_t hz = v->as_u32();
                if (!is(p::ValueType::U32) || hz < kMinSampleRateHz || hz > kMaxSampleRateHz) {
                    return bad(u32(settings_.sample_rate_hz));
                }
                settings_.sample_rate_hz = hz;
                // Output rates above the new sample rate are lowered to it.
                if (settings_.orientation_rate_hz > hz) settings_.orientation_rate_hz = hz;
                if (settings_.raw_rate_hz > hz) settings_.raw_rate_hz = hz;
                restart_schedules(now);
            }
            ack.value = u32(settings_.sample_rate_hz);
            return ack;
        }
        case board_key::kFusionKp:
        case board_key::kFusionKi: {
            if (!imu_.has_gains()) {
                // This IMU fuses on its own chip (BNO055): the gains do not exist here.
                ack.status = p::ConfigStatus::UnknownKey;
                return ack;
            }
            float kp = 0, ki = 0;
            imu_.gains(kp, ki);
            float& gain = key == board_key::kFusionKp ? kp : ki;
            if (v != nullptr) {
                if (!is(p::ValueType::F32) || !std::isfinite(v->as_f32())) {
                    return bad(p::ConfigValue::from_f32(gain));
                }
                const float old = gain;
                gain = v->as_f32();
                if (!imu_.set_gains(kp, ki)) {
                    return bad(p::ConfigValue::from_f32(old));
                }
            }
            ack.value = p::ConfigValue::from_f32(gain);
            return ack;
        }
        default:
            ack.status = p::ConfigStatus::UnknownKey;
            return ack;
    }
}

void Firmware::read_buttons(std::uint64_t now_us) {
    const std::uint32_t debounce_us = settings_.button_debounce_ms * 1000;
    for (std::uint8_t id = 0; id < info_.button_count; ++id) {
        const ButtonDebouncer::Edge edge =
            buttons_[id].sample(hal_.gpio.button_pressed(id), now_us, debounce_us);
        if (edge.happened) {
            send(p::ButtonEvent{edge.timestamp_us, id,
                                edge.pressed ? p::ButtonState::Pressed : p::ButtonState::Released});
        }
    }
}

void Firmware::report_sensor_fault(ImuStatus status, std::uint64_t now_us) {
    ++stats_.sensor_faults;
    // First failure of an episode at once, then once a second while it lasts.
    const bool new_episode = last_imu_status_ == ImuStatus::Ok || last_imu_status_ == ImuStatus::Starting;
    if (!sensor_error_limit_.allow(now_us, new_episode)) return;
    send_error(status == ImuStatus::NotResponding ? p::ErrorCode::SensorNotResponding
                                                  : p::ErrorCode::SensorReadFailed,
               imu_.last_fault_sensors(), now_us);
}

void Firmware::sample(std::uint64_t now_us) {
    ImuReading reading;
    const ImuStatus status = imu_.poll(now_us, reading);
    if (status == ImuStatus::ReadFailed || status == ImuStatus::NotResponding ||
        status == ImuStatus::Degraded) {
        report_sensor_fault(status == ImuStatus::Degraded ? ImuStatus::NotResponding : status, now_us);
    }
    if (status != ImuStatus::Degraded) last_imu_status_ = status;
    if (status != ImuStatus::Ok && status != ImuStatus::Degraded) {
        have_reading_ = false;
        return;
    }
    ++stats_.samples;
    reading_ = reading;
    have_reading_ = true;

    if (orientation_schedule_.take(now_us) && reading.has_orientation) {
        const Quatf q = normalized(reading.world_from_sensor);
        send(p::Orientation{reading.timestamp_us, p::to_q30(q.w), p::to_q30(q.x), p::to_q30(q.y),
                            p::to_q30(q.z)});
    }
    if (raw_schedule_.take(now_us)) {
        send(p::RawImu{reading.timestamp_us, scaled_i32(reading.gyro_rad_s, kMicro),
                       scaled_i32(reading.accel_m_s2, kMicro), scaled_i32(reading.mag_ut, kNanoTesla),
                       reading.raw_valid});
    }
    // A change of calibration or mode is news: send it now rather than at the next second.
    if (reading.calibration != last_sent_calibration_ || imu_.mode() != last_sent_mode_) {
        send_fusion_status(now_us);
    }
}

void Firmware::send_fusion_status(std::uint64_t now_us) {
    const CalibrationLevels c = have_reading_ ? reading_.calibration : CalibrationLevels{};
    const Vec3f bias = have_reading_ ? reading_.gyro_bias_rad_s : Vec3f{};
    if (send(p::FusionStatus{now_us, imu_.mode(), c.system, c.gyro, c.accel, c.mag, scaled_i32(bias, kMicro)})) {
        last_sent_calibration_ = c;
        last_sent_mode_ = imu_.mode();
    }
    next_fusion_status_us_ = now_us + kFusionStatusPeriodUs;
}

// Lamp: steady on while the IMU delivers samples, blinking at 2 Hz while it does not.
void Firmware::update_lamp(std::uint64_t now_us) {
    const bool healthy = have_reading_;
    const bool on = healthy || ((now_us - start_us_) / kLampBlinkHalfPeriodUs) % 2 == 0;
    if (on != lamp_on_) {
        lamp_on_ = on;
        hal_.gpio.set_lamp(on);
    }
}

}  // namespace glint::firmware
