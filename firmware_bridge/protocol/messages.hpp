// Messages of the Glint sensor-board protocol: type bytes, payload structs with their units,
// and the payload codec. Byte layouts are specified in PROTOCOL.md; this header is the code
// side of that document. Freestanding-friendly: no heap, no exceptions, no RTTI, no OS.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

namespace glint::protocol {

// Version of this wire format. A receiver rejects frames of another major version; a newer
// minor version may only append payload fields (see PROTOCOL.md "Versioning").
inline constexpr std::uint8_t kVersionMajor = 1;
inline constexpr std::uint8_t kVersionMinor = 0;

// Largest payload a frame may carry (so that the COBS-encoded frame fits 255 bytes + delimiter).
inline constexpr std::size_t kMaxPayloadSize = 246;

// Type byte of every message. 0x01..0x0F are sent by the sensor board, 0x10..0x1F by the
// appliance; the codec itself accepts any message in both directions.
enum class MessageType : std::uint8_t {
    Hello = 0x01,
    Orientation = 0x02,
    RawImu = 0x03,
    FusionStatus = 0x04,
    ButtonEvent = 0x05,
    Heartbeat = 0x06,
    ErrorReport = 0x07,
    ConfigAck = 0x08,
    HelloRequest = 0x10,
    ConfigGet = 0x11,
    ConfigSet = 0x12,
};

bool is_known_type(std::uint8_t type);
// Lower-case name for logs ("orientation"); "unknown" for a type this version does not know.
const char* type_name(std::uint8_t type);
// Payload size in bytes that this version writes for `type`; 0 for unknown types (and for
// HelloRequest, whose payload is empty: check is_known_type first).
std::size_t payload_size(MessageType type);

// Capability bits of Hello::capabilities.
namespace capability {
inline constexpr std::uint32_t kGyro = 1u << 0;           // a gyroscope is fitted
inline constexpr std::uint32_t kAccel = 1u << 1;          // an accelerometer is fitted
inline constexpr std::uint32_t kMag = 1u << 2;            // a magnetometer is fitted
inline constexpr std::uint32_t kOnBoardFusion = 1u << 3;  // the board sends Orientation
inline constexpr std::uint32_t kRawImu = 1u << 4;         // the board can send RawImu
inline constexpr std::uint32_t kButtons = 1u << 5;        // the board sends ButtonEvent
}  // namespace capability

// Board -> appliance, first frame after every reset (with sequence number 0) and on request.
struct Hello {
    std::uint8_t protocol_major;
    std::uint8_t protocol_minor;
    std::uint8_t firmware_major;
    std::uint8_t firmware_minor;
    std::uint16_t firmware_patch;
    std::uint32_t board_id;      // unique per board (e.g. a hash of the MCU's unique id)
    std::uint32_t capabilities;  // capability::k* bits
    std::uint8_t button_count;   // buttons numbered 0 .. button_count-1
    friend bool operator==(const Hello&, const Hello&) = default;
};

// Fixed-point scale of quaternion components: value = raw / 2^30 (Q2.30, range [-2, 2)).
inline constexpr std::int32_t kQ30One = 1 << 30;

// Nearest Q30 integer of a real number, saturated to the int32 range.
constexpr std::int32_t to_q30(double value) {
    const double scaled = value * static_cast<double>(kQ30One);
    if (!(scaled > -2147483648.0)) return INT32_MIN;  // also catches NaN
    if (scaled >= 2147483647.0) return INT32_MAX;
    return static_cast<std::int32_t>(scaled < 0 ? scaled - 0.5 : scaled + 0.5);
}
constexpr double from_q30(std::int32_t raw) { return static_cast<double>(raw) / kQ30One; }

// Board -> appliance: the rotation that takes vectors from the sensor frame to the world frame
// (right-handed, +Y up, -Z forward; docs/conventions.md): v_world = q * v_sensor * conj(q).
// Components in Q30; the receiver accepts |q| in [0.9, 1.1] and renormalises.
struct Orientation {
    std::uint64_t timestamp_us;  // board clock, microseconds since board reset
    std::int32_t w_q30;
    std::int32_t x_q30;
    std::int32_t y_q30;
    std::int32_t z_q30;
    friend bool operator==(const Orientation&, const Orientation&) = default;
};

// Bits of RawImu::valid: which of the three vectors hold a measurement in this sample.
namespace raw_valid {
inline constexpr std::uint8_t kGyro = 1u << 0;
inline constexpr std::uint8_t kAccel = 1u << 1;
inline constexpr std::uint8_t kMag = 1u << 2;
}  // namespace raw_valid

// Board -> appliance: one calibrated IMU sample in the sensor frame (x, y, z as marked on the
// board, right-handed). Integer micro-units keep NaN off the wire and need no FPU.
struct RawImu {
    std::uint64_t timestamp_us;               // board clock, microseconds since board reset
    std::array<std::int32_t, 3> gyro_urad_s;  // angular rate, 1e-6 rad/s per LSB
    std::array<std::int32_t, 3> accel_um_s2;  // specific force, 1e-6 m/s^2 per LSB
    std::array<std::int32_t, 3> mag_nt;       // magnetic field, 1e-3 microtesla (1 nT) per LSB
    std::uint8_t valid;                       // raw_valid::k* bits
    friend bool operator==(const RawImu&, const RawImu&) = default;
};

enum class FusionMode : std::uint8_t {
    Off = 0,   // no fusion running: raw samples only
    Imu = 1,   // gyro + accel: absolute pitch/roll, yaw relative to start
    Ndof = 2,  // gyro + accel + mag: absolute heading
};
inline constexpr std::uint8_t kMaxCalibrationLevel = 3;  // 0 = uncalibrated .. 3 = fully

// Board -> appliance: state of the on-board fusion and calibration.
struct FusionStatus {
    std::uint64_t timestamp_us;  // board clock, microseconds since board reset
    FusionMode mode;
    std::uint8_t calib_system;   // 0..3
    std::uint8_t calib_gyro;     // 0..3
    std::uint8_t calib_accel;    // 0..3
    std::uint8_t calib_mag;      // 0..3
    std::array<std::int32_t, 3> gyro_bias_urad_s;  // current bias estimate, sensor frame
    friend bool operator==(const FusionStatus&, const FusionStatus&) = default;
};

enum class ButtonState : std::uint8_t { Released = 0, Pressed = 1 };

// Board -> appliance: a debounced button edge.
struct ButtonEvent {
    std::uint64_t timestamp_us;  // board clock at the (debounced) edge
    std::uint8_t button_id;      // 0 .. Hello::button_count-1
    ButtonState state;
    friend bool operator==(const ButtonEvent&, const ButtonEvent&) = default;
};

// Board -> appliance, periodically: liveness and the board's own link counters.
struct Heartbeat {
    std::uint64_t timestamp_us;    // board clock
    std::uint32_t uptime_s;        // seconds since firmware start
    std::uint32_t frames_sent;     // frames the board has sent since reset (wraps)
    std::uint32_t frames_dropped;  // frames the board could not send (transmit buffer full)
    std::uint32_t rx_frames_ok;    // frames the board received and accepted
    std::uint32_t rx_frames_bad;   // frames the board received and rejected (any error)
    friend bool operator==(const Heartbeat&, const Heartbeat&) = default;
};

// Error codes of ErrorReport (open set: receivers pass unknown codes on unchanged).
enum class ErrorCode : std::uint16_t {
    SensorNotResponding = 0x0001,  // detail: sensor bit (capability::kGyro...)
    SensorReadFailed = 0x0002,     // detail: sensor bit
    TransmitOverflow = 0x0003,     // detail: frames dropped since the last report
    ReceivedBadFrame = 0x0004,     // detail: FrameStatus value of the rejected frame
    ReceivedUnknownType = 0x0005,  // detail: the type byte
    ReceivedBadLength = 0x0006,    // detail: type byte << 16 | payload length
    WatchdogReset = 0x0007,        // detail: 0
    CalibrationStoreFailed = 0x0008,
};

// Either direction: something went wrong on the sender's side.
struct ErrorReport {
    std::uint64_t timestamp_us;  // sender's clock
    std::uint16_t code;          // ErrorCode value, or a newer one
    std::uint32_t detail;        // meaning depends on code
    friend bool operator==(const ErrorReport&, const ErrorReport&) = default;
};

// Configuration keys (open set: the board answers keys it does not know with UnknownKey).
enum class ConfigKey : std::uint16_t {
    OrientationRateHz = 0x0001,  // U32, Orientation frames per second (0 = off)
    RawImuRateHz = 0x0002,       // U32, RawImu frames per second (0 = off)
    FusionModeKey = 0x0003,      // U32, a FusionMode value
    HeartbeatPeriodMs = 0x0004,  // U32, milliseconds between Heartbeats (0 = off)
    BoardId = 0x0005,            // U32, read-only
    MagEnabled = 0x0006,         // Bool
    ButtonDebounceMs = 0x0007,   // U32
};

enum class ValueType : std::uint8_t { U32 = 0, I32 = 1, F32 = 2, Bool = 3 };

// A typed 32-bit configuration value; `bits` holds the value's little-endian bit pattern.
struct ConfigValue {
    ValueType type;
    std::uint32_t bits;
    friend bool operator==(const ConfigValue&, const ConfigValue&) = default;

    static ConfigValue from_u32(std::uint32_t v) { return {ValueType::U32, v}; }
    static ConfigValue from_i32(std::int32_t v) { return {ValueType::I32, static_cast<std::uint32_t>(v)}; }
    static ConfigValue from_f32(float v);
    static ConfigValue from_bool(bool v) { return {ValueType::Bool, v ? 1u : 0u}; }
    std::uint32_t as_u32() const { return bits; }
    std::int32_t as_i32() const { return static_cast<std::int32_t>(bits); }
    float as_f32() const;
    bool as_bool() const { return bits != 0; }
};

enum class ConfigStatus : std::uint8_t { Ok = 0, UnknownKey = 1, BadValue = 2, ReadOnly = 3 };

// Appliance -> board: ask the board to send Hello again (empty payload).
struct HelloRequest {
    friend bool operator==(const HelloRequest&, const HelloRequest&) = default;
};

// Appliance -> board: read one key. Answered by a ConfigAck.
struct ConfigGet {
    std::uint16_t key;
    friend bool operator==(const ConfigGet&, const ConfigGet&) = default;
};

// Appliance -> board: write one key. Answered by a ConfigAck.
struct ConfigSet {
    std::uint16_t key;
    ConfigValue value;
    friend bool operator==(const ConfigSet&, const ConfigSet&) = default;
};

// Board -> appliance: the answer to one ConfigGet or ConfigSet.
struct ConfigAck {
    std::uint16_t request_seq;  // sequence number of the frame this answers
    std::uint16_t key;
    ConfigStatus status;
    ConfigValue value;          // the key's value after the request (meaningless unless Ok/ReadOnly)
    friend bool operator==(const ConfigAck&, const ConfigAck&) = default;
};

// One decoded message: a tagged union, trivially copyable, no heap.
struct Message {
    MessageType type;
    union {
        Hello hello;
        Orientation orientation;
        RawImu raw_imu;
        FusionStatus fusion_status;
        ButtonEvent button_event;
        Heartbeat heartbeat;
        ErrorReport error_report;
        ConfigAck config_ack;
        HelloRequest hello_request;
        ConfigGet config_get;
        ConfigSet config_set;
    };

    Message() : type(MessageType::HelloRequest), hello_request{} {}
    Message(const Hello& m) : type(MessageType::Hello), hello(m) {}
    Message(const Orientation& m) : type(MessageType::Orientation), orientation(m) {}
    Message(const RawImu& m) : type(MessageType::RawImu), raw_imu(m) {}
    Message(const FusionStatus& m) : type(MessageType::FusionStatus), fusion_status(m) {}
    Message(const ButtonEvent& m) : type(MessageType::ButtonEvent), button_event(m) {}
    Message(const Heartbeat& m) : type(MessageType::Heartbeat), heartbeat(m) {}
    Message(const ErrorReport& m) : type(MessageType::ErrorReport), error_report(m) {}
    Message(const ConfigAck& m) : type(MessageType::ConfigAck), config_ack(m) {}
    Message(const HelloRequest& m) : type(MessageType::HelloRequest), hello_request(m) {}
    Message(const ConfigGet& m) : type(MessageType::ConfigGet), config_get(m) {}
    Message(const ConfigSet& m) : type(MessageType::ConfigSet), config_set(m) {}
};

// Same type and same fields (the inactive union bytes are not compared).
bool operator==(const Message& a, const Message& b);

// Whether every enumerated or ranged field holds a value this version defines (calibration
// levels 0..3, known FusionMode / ButtonState / ValueType / ConfigStatus, Bool 0 or 1,
// quaternion norm in [0.9, 1.1], known type).
bool is_valid(const Message& message);

enum class PayloadStatus : std::uint8_t {
    Ok = 0,
    UnknownType,     // type byte not defined by this version
    BadLength,       // payload shorter than this version's layout of the type
    BadValue,        // a field holds a value outside its range (see is_valid)
    BufferTooSmall,  // encode only: the output span cannot hold the payload
};
const char* status_name(PayloadStatus status);

struct PayloadResult {
    PayloadStatus status = PayloadStatus::Ok;
    std::size_t size = 0;  // bytes written (encode) when Ok
};

// Writes the payload of `message` (no header, no CRC). Refuses invalid messages (BadValue).
PayloadResult encode_payload(const Message& message, std::span<std::uint8_t> out);

// Reads a payload of type `type`. A payload longer than this version's layout is accepted and
// its extra bytes are ignored (a newer minor version appended fields); a shorter one is
// BadLength. `out` is only meaningful when the result is Ok.
PayloadStatus decode_payload(std::uint8_t type, std::span<const std::uint8_t> payload, Message& out);

}  // namespace glint::protocol
