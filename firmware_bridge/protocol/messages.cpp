// Payload codec: one writer and one reader per message type, offsets exactly as in the payload
// tables of PROTOCOL.md. Every read is bounds-checked against the payload span first.
#include "firmware_bridge/protocol/messages.hpp"

#include <cstring>

#include "firmware_bridge/protocol/byte_io.hpp"

namespace glint::protocol {

using namespace byte_io;

namespace {

// Payload sizes of version 1.0 (PROTOCOL.md, one table per message).
constexpr std::size_t kHelloSize = 15;
constexpr std::size_t kOrientationSize = 24;
constexpr std::size_t kRawImuSize = 45;
constexpr std::size_t kFusionStatusSize = 25;
constexpr std::size_t kButtonEventSize = 10;
constexpr std::size_t kHeartbeatSize = 28;
constexpr std::size_t kErrorReportSize = 14;
constexpr std::size_t kConfigAckSize = 10;
constexpr std::size_t kHelloRequestSize = 0;
constexpr std::size_t kConfigGetSize = 2;
constexpr std::size_t kConfigSetSize = 7;

// Accepted squared norm of a quaternion, in units of 2^30 after reducing each component to
// Q15 (so four squares fit an int64 with room): |q| in [0.9, 1.1]. A unit quaternion carries
// quantisation error ~1e-9, so this only rejects firmware bugs (zero or unnormalised output).
constexpr std::int64_t kNormSquaredMin = static_cast<std::int64_t>(0.81 * (1 << 30));
constexpr std::int64_t kNormSquaredMax = static_cast<std::int64_t>(1.21 * (1 << 30));

bool quaternion_norm_ok(const Orientation& o) {
    std::int64_t sum = 0;
    for (const std::int32_t c : {o.w_q30, o.x_q30, o.y_q30, o.z_q30}) {
        const std::int64_t q15 = c >> 15;  // arithmetic shift (defined in C++20)
        sum += q15 * q15;
    }
    return sum >= kNormSquaredMin && sum <= kNormSquaredMax;
}

bool value_ok(const ConfigValue& v) {
    switch (v.type) {
        case ValueType::U32:
        case ValueType::I32:
        case ValueType::F32:
            return true;
        case ValueType::Bool:
            return v.bits <= 1;
    }
    return false;
}

void put_vec3(std::uint8_t* p, const std::array<std::int32_t, 3>& v) {
    for (std::size_t i = 0; i < 3; ++i) put_i32(p + 4 * i, v[i]);
}

std::array<std::int32_t, 3> get_vec3(const std::uint8_t* p) {
    return {get_i32(p), get_i32(p + 4), get_i32(p + 8)};
}

void put_value(std::uint8_t* p, const ConfigValue& v) {
    put_u8(p, static_cast<std::uint8_t>(v.type));
    put_u32(p + 1, v.bits);
}

ConfigValue get_value(const std::uint8_t* p) {
    return {static_cast<ValueType>(get_u8(p)), get_u32(p + 1)};
}

}  // namespace

ConfigValue ConfigValue::from_f32(float v) {
    static_assert(sizeof(float) == 4, "float must be IEEE-754 binary32");
    std::uint32_t bits = 0;
    std::memcpy(&bits, &v, sizeof bits);
    return {ValueType::F32, bits};
}

float ConfigValue::as_f32() const {
    float v = 0;
    std::memcpy(&v, &bits, sizeof v);
    return v;
}

bool is_known_type(std::uint8_t type) {
    switch (static_cast<MessageType>(type)) {
        case MessageType::Hello:
        case MessageType::Orientation:
        case MessageType::RawImu:
        case MessageType::FusionStatus:
        case MessageType::ButtonEvent:
        case MessageType::Heartbeat:
        case MessageType::ErrorReport:
        case MessageType::ConfigAck:
        case MessageType::HelloRequest:
        case MessageType::ConfigGet:
        case MessageType::ConfigSet:
            return true;
    }
    return false;
}

const char* type_name(std::uint8_t type) {
    switch (static_cast<MessageType>(type)) {
        case MessageType::Hello: return "hello";
        case MessageType::Orientation: return "orientation";
        case MessageType::RawImu: return "raw_imu";
        case MessageType::FusionStatus: return "fusion_status";
        case MessageType::ButtonEvent: return "button_event";
        case MessageType::Heartbeat: return "heartbeat";
        case MessageType::ErrorReport: return "error_report";
        case MessageType::ConfigAck: return "config_ack";
        case MessageType::HelloRequest: return "hello_request";
        case MessageType::ConfigGet: return "config_get";
        case MessageType::ConfigSet: return "config_set";
    }
    return "unknown";
}

std::size_t payload_size(MessageType type) {
    switch (type) {
        case MessageType::Hello: return kHelloSize;
        case MessageType::Orientation: return kOrientationSize;
        case MessageType::RawImu: return kRawImuSize;
        case MessageType::FusionStatus: return kFusionStatusSize;
        case MessageType::ButtonEvent: return kButtonEventSize;
        case MessageType::Heartbeat: return kHeartbeatSize;
        case MessageType::ErrorReport: return kErrorReportSize;
        case MessageType::ConfigAck: return kConfigAckSize;
        case MessageType::HelloRequest: return kHelloRequestSize;
        case MessageType::ConfigGet: return kConfigGetSize;
        case MessageType::ConfigSet: return kConfigSetSize;
    }
    return 0;
}

const char* status_name(PayloadStatus status) {
    switch (status) {
        case PayloadStatus::Ok: return "ok";
        case PayloadStatus::UnknownType: return "unknown type";
        case PayloadStatus::BadLength: return "payload too short";
        case PayloadStatus::BadValue: return "field out of range";
        case PayloadStatus::BufferTooSmall: return "output buffer too small";
    }
    return "invalid status";
}

bool operator==(const Message& a, const Message& b) {
    if (a.type != b.type) return false;
    switch (a.type) {
        case MessageType::Hello: return a.hello == b.hello;
        case MessageType::Orientation: return a.orientation == b.orientation;
        case MessageType::RawImu: return a.raw_imu == b.raw_imu;
        case MessageType::FusionStatus: return a.fusion_status == b.fusion_status;
        case MessageType::ButtonEvent: return a.button_event == b.button_event;
        case MessageType::Heartbeat: return a.heartbeat == b.heartbeat;
        case MessageType::ErrorReport: return a.error_report == b.error_report;
        case MessageType::ConfigAck: return a.config_ack == b.config_ack;
        case MessageType::HelloRequest: return true;
        case MessageType::ConfigGet: return a.config_get == b.config_get;
        case MessageType::ConfigSet: return a.config_set == b.config_set;
    }
    return false;
}

bool is_valid(const Message& m) {
    switch (m.type) {
        case MessageType::Orientation:
            return quaternion_norm_ok(m.orientation);
        case MessageType::FusionStatus: {
            const FusionStatus& f = m.fusion_status;
            return static_cast<std::uint8_t>(f.mode) <= static_cast<std::uint8_t>(FusionMode::Ndof) &&
                   f.calib_system <= kMaxCalibrationLevel && f.calib_gyro <= kMaxCalibrationLevel &&
                   f.calib_accel <= kMaxCalibrationLevel && f.calib_mag <= kMaxCalibrationLevel;
        }
        case MessageType::ButtonEvent:
            return m.button_event.state == ButtonState::Released ||
                   m.button_event.state == ButtonState::Pressed;
        case MessageType::ConfigAck:
            return static_cast<std::uint8_t>(m.config_ack.status) <=
                       static_cast<std::uint8_t>(ConfigStatus::ReadOnly) &&
                   value_ok(m.config_ack.value);
        case MessageType::ConfigSet:
            return value_ok(m.config_set.value);
        case MessageType::Hello:
        case MessageType::RawImu:
        case MessageType::Heartbeat:
        case MessageType::ErrorReport:
        case MessageType::HelloRequest:
        case MessageType::ConfigGet:
            return true;
    }
    return false;  // a type value outside the enumeration
}

PayloadResult encode_payload(const Message& m, std::span<std::uint8_t> out) {
    if (!is_known_type(static_cast<std::uint8_t>(m.type))) return {PayloadStatus::UnknownType, 0};
    if (!is_valid(m)) return {PayloadStatus::BadValue, 0};
    const std::size_t size = payload_size(m.type);
    if (out.size() < size) return {PayloadStatus::BufferTooSmall, 0};
    std::uint8_t* p = out.data();
    switch (m.type) {
        case MessageType::Hello: {
            const Hello& h = m.hello;
            put_u8(p + 0, h.protocol_major);
            put_u8(p + 1, h.protocol_minor);
            put_u8(p + 2, h.firmware_major);
            put_u8(p + 3, h.firmware_minor);
            put_u16(p + 4, h.firmware_patch);
            put_u32(p + 6, h.board_id);
            put_u32(p + 10, h.capabilities);
            put_u8(p + 14, h.button_count);
            break;
        }
        case MessageType::Orientation: {
            const Orientation& o = m.orientation;
            put_u64(p + 0, o.timestamp_us);
            put_i32(p + 8, o.w_q30);
            put_i32(p + 12, o.x_q30);
            put_i32(p + 16, o.y_q30);
            put_i32(p + 20, o.z_q30);
            break;
        }
        case MessageType::RawImu: {
            const RawImu& r = m.raw_imu;
            put_u64(p + 0, r.timestamp_us);
            put_vec3(p + 8, r.gyro_urad_s);
            put_vec3(p + 20, r.accel_um_s2);
            put_vec3(p + 32, r.mag_nt);
            put_u8(p + 44, r.valid);
            break;
        }
        case MessageType::FusionStatus: {
            const FusionStatus& f = m.fusion_status;
            put_u64(p + 0, f.timestamp_us);
            put_u8(p + 8, static_cast<std::uint8_t>(f.mode));
            put_u8(p + 9, f.calib_system);
            put_u8(p + 10, f.calib_gyro);
            put_u8(p + 11, f.calib_accel);
            put_u8(p + 12, f.calib_mag);
            put_vec3(p + 13, f.gyro_bias_urad_s);
            break;
        }
        case MessageType::ButtonEvent: {
            const ButtonEvent& b = m.button_event;
            put_u64(p + 0, b.timestamp_us);
            put_u8(p + 8, b.button_id);
            put_u8(p + 9, static_cast<std::uint8_t>(b.state));
            break;
        }
        case MessageType::Heartbeat: {
            const Heartbeat& h = m.heartbeat;
            put_u64(p + 0, h.timestamp_us);
            put_u32(p + 8, h.uptime_s);
            put_u32(p + 12, h.frames_sent);
            put_u32(p + 16, h.frames_dropped);
            put_u32(p + 20, h.rx_frames_ok);
            put_u32(p + 24, h.rx_frames_bad);
            break;
        }
        case MessageType::ErrorReport: {
            const ErrorReport& e = m.error_report;
            put_u64(p + 0, e.timestamp_us);
            put_u16(p + 8, e.code);
            put_u32(p + 10, e.detail);
            break;
        }
        case MessageType::ConfigAck: {
            const ConfigAck& a = m.config_ack;
            put_u16(p + 0, a.request_seq);
            put_u16(p + 2, a.key);
            put_u8(p + 4, static_cast<std::uint8_t>(a.status));
            put_value(p + 5, a.value);
            break;
        }
        case MessageType::HelloRequest:
            break;
        case MessageType::ConfigGet:
            put_u16(p + 0, m.config_get.key);
            break;
        case MessageType::ConfigSet:
            put_u16(p + 0, m.config_set.key);
            put_value(p + 2, m.config_set.value);
            break;
    }
    return {PayloadStatus::Ok, size};
}

PayloadStatus decode_payload(std::uint8_t type, std::span<const std::uint8_t> payload, Message& out) {
    if (!is_known_type(type)) return PayloadStatus::UnknownType;
    const auto message_type = static_cast<MessageType>(type);
    if (payload.size() < payload_size(message_type)) return PayloadStatus::BadLength;
    const std::uint8_t* p = payload.data();
    switch (message_type) {
        case MessageType::Hello: {
            Hello h{};
            h.protocol_major = get_u8(p + 0);
            h.protocol_minor = get_u8(p + 1);
            h.firmware_major = get_u8(p + 2);
            h.firmware_minor = get_u8(p + 3);
            h.firmware_patch = get_u16(p + 4);
            h.board_id = get_u32(p + 6);
            h.capabilities = get_u32(p + 10);
            h.button_count = get_u8(p + 14);
            out = h;
            break;
        }
        case MessageType::Orientation: {
            Orientation o{};
            o.timestamp_us = get_u64(p + 0);
            o.w_q30 = get_i32(p + 8);
            o.x_q30 = get_i32(p + 12);
            o.y_q30 = get_i32(p + 16);
            o.z_q30 = get_i32(p + 20);
            out = o;
            break;
        }
        case MessageType::RawImu: {
            RawImu r{};
            r.timestamp_us = get_u64(p + 0);
            r.gyro_urad_s = get_vec3(p + 8);
            r.accel_um_s2 = get_vec3(p + 20);
            r.mag_nt = get_vec3(p + 32);
            r.valid = get_u8(p + 44);
            out = r;
            break;
        }
        case MessageType::FusionStatus: {
            FusionStatus f{};
            f.timestamp_us = get_u64(p + 0);
            f.mode = static_cast<FusionMode>(get_u8(p + 8));
            f.calib_system = get_u8(p + 9);
            f.calib_gyro = get_u8(p + 10);
            f.calib_accel = get_u8(p + 11);
            f.calib_mag = get_u8(p + 12);
            f.gyro_bias_urad_s = get_vec3(p + 13);
            out = f;
            break;
        }
        case MessageType::ButtonEvent: {
            ButtonEvent b{};
            b.timestamp_us = get_u64(p + 0);
            b.button_id = get_u8(p + 8);
            b.state = static_cast<ButtonState>(get_u8(p + 9));
            out = b;
            break;
        }
        case MessageType::Heartbeat: {
            Heartbeat h{};
            h.timestamp_us = get_u64(p + 0);
            h.uptime_s = get_u32(p + 8);
            h.frames_sent = get_u32(p + 12);
            h.frames_dropped = get_u32(p + 16);
            h.rx_frames_ok = get_u32(p + 20);
            h.rx_frames_bad = get_u32(p + 24);
            out = h;
            break;
        }
        case MessageType::ErrorReport: {
            ErrorReport e{};
            e.timestamp_us = get_u64(p + 0);
            e.code = get_u16(p + 8);
            e.detail = get_u32(p + 10);
            out = e;
            break;
        }
        case MessageType::ConfigAck: {
            ConfigAck a{};
            a.request_seq = get_u16(p + 0);
            a.key = get_u16(p + 2);
            a.status = static_cast<ConfigStatus>(get_u8(p + 4));
            a.value = get_value(p + 5);
            out = a;
            break;
        }
        case MessageType::HelloRequest:
            out = HelloRequest{};
            break;
        case MessageType::ConfigGet:
            out = ConfigGet{get_u16(p + 0)};
            break;
        case MessageType::ConfigSet:
            out = ConfigSet{get_u16(p + 0), get_value(p + 2)};
            break;
    }
    return is_valid(out) ? PayloadStatus::Ok : PayloadStatus::BadValue;
}

}  // namespace glint::protocol
