// Payload codec. Each message's fields are listed once, with their offsets as in the payload
// tables of PROTOCOL.md (`describe` below); encode, decode and a compile-time layout check all
// walk that one list, so the writer and the reader cannot disagree on a field. Every read is
// bounds-checked against the payload span first (decode_payload checks the size).
#include "firmware_bridge/protocol/messages.hpp"

#include <concepts>
#include <cstring>
#include <type_traits>

#include "firmware_bridge/protocol/byte_io.hpp"

namespace glint::protocol {

using namespace byte_io;

namespace {

// Payload sizes of version 1.0 (PROTOCOL.md, one table per message). Each message's description
// below must add up to exactly this (checked at compile time).
template <typename T>
constexpr std::size_t kPayloadSize = 0;
template <> constexpr std::size_t kPayloadSize<Hello> = 15;
template <> constexpr std::size_t kPayloadSize<Orientation> = 24;
template <> constexpr std::size_t kPayloadSize<RawImu> = 45;
template <> constexpr std::size_t kPayloadSize<FusionStatus> = 25;
template <> constexpr std::size_t kPayloadSize<ButtonEvent> = 10;
template <> constexpr std::size_t kPayloadSize<Heartbeat> = 28;
template <> constexpr std::size_t kPayloadSize<ErrorReport> = 14;
template <> constexpr std::size_t kPayloadSize<ConfigAck> = 10;
template <> constexpr std::size_t kPayloadSize<HelloRequest> = 0;
template <> constexpr std::size_t kPayloadSize<ConfigGet> = 2;
template <> constexpr std::size_t kPayloadSize<ConfigSet> = 7;

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

// ---- How one field is laid out: its size on the wire, how it is written and read ----------

// The integer types map one to one onto the wire types u8, u16, u32, u64 and i32.
template <typename T, void (*Put)(std::uint8_t*, T), T (*Get)(const std::uint8_t*)>
struct IntegerCodec {
    static constexpr std::size_t size = sizeof(T);
    static void put(std::uint8_t* p, T v) { Put(p, v); }
    static T get(const std::uint8_t* p) { return Get(p); }
};

template <typename T>
struct FieldCodec;
template <> struct FieldCodec<std::uint8_t> : IntegerCodec<std::uint8_t, put_u8, get_u8> {};
template <> struct FieldCodec<std::uint16_t> : IntegerCodec<std::uint16_t, put_u16, get_u16> {};
template <> struct FieldCodec<std::uint32_t> : IntegerCodec<std::uint32_t, put_u32, get_u32> {};
template <> struct FieldCodec<std::uint64_t> : IntegerCodec<std::uint64_t, put_u64, get_u64> {};
template <> struct FieldCodec<std::int32_t> : IntegerCodec<std::int32_t, put_i32, get_i32> {};

// An enumeration travels as its underlying integer (all of PROTOCOL.md's are u8). The decoded
// value may be outside the enumeration; is_valid() catches that.
template <typename E>
    requires std::is_enum_v<E>
struct FieldCodec<E> {
    using Raw = std::underlying_type_t<E>;
    static constexpr std::size_t size = FieldCodec<Raw>::size;
    static void put(std::uint8_t* p, E v) { FieldCodec<Raw>::put(p, static_cast<Raw>(v)); }
    static E get(const std::uint8_t* p) { return static_cast<E>(FieldCodec<Raw>::get(p)); }
};

// "i32 x 3": x, y, z.
template <>
struct FieldCodec<std::array<std::int32_t, 3>> {
    static constexpr std::size_t size = 12;
    static void put(std::uint8_t* p, const std::array<std::int32_t, 3>& v) {
        for (std::size_t i = 0; i < 3; ++i) put_i32(p + 4 * i, v[i]);
    }
    static std::array<std::int32_t, 3> get(const std::uint8_t* p) {
        return {get_i32(p), get_i32(p + 4), get_i32(p + 8)};
    }
};

// value_type u8, then the value bits u32.
template <>
struct FieldCodec<ConfigValue> {
    static constexpr std::size_t size = 5;
    static void put(std::uint8_t* p, const ConfigValue& v) {
        put_u8(p, static_cast<std::uint8_t>(v.type));
        put_u32(p + 1, v.bits);
    }
    static ConfigValue get(const std::uint8_t* p) {
        return {static_cast<ValueType>(get_u8(p)), get_u32(p + 1)};
    }
};

// ---- What each payload holds: one description per message, used in both directions --------
//
// describe(io, message) calls io(offset, field) for every field in wire order; the offsets are
// those of PROTOCOL.md's tables and each field's C++ type picks its wire type (FieldCodec), so a
// struct field whose type changes size fails the compile-time LayoutCheck below.
// `message` is const when encoding and mutable when decoding, hence the PayloadOf constraint.

template <typename M, typename T>
concept PayloadOf = std::same_as<std::remove_const_t<M>, T>;

template <typename Io>
constexpr void describe(Io& io, PayloadOf<Hello> auto& h) {
    io(0, h.protocol_major);
    io(1, h.protocol_minor);
    io(2, h.firmware_major);
    io(3, h.firmware_minor);
    io(4, h.firmware_patch);
    io(6, h.board_id);
    io(10, h.capabilities);
    io(14, h.button_count);
}

template <typename Io>
constexpr void describe(Io& io, PayloadOf<Orientation> auto& o) {
    io(0, o.timestamp_us);
    io(8, o.w_q30);
    io(12, o.x_q30);
    io(16, o.y_q30);
    io(20, o.z_q30);
}

template <typename Io>
constexpr void describe(Io& io, PayloadOf<RawImu> auto& r) {
    io(0, r.timestamp_us);
    io(8, r.gyro_urad_s);
    io(20, r.accel_um_s2);
    io(32, r.mag_nt);
    io(44, r.valid);
}

template <typename Io>
constexpr void describe(Io& io, PayloadOf<FusionStatus> auto& f) {
    io(0, f.timestamp_us);
    io(8, f.mode);
    io(9, f.calib_system);
    io(10, f.calib_gyro);
    io(11, f.calib_accel);
    io(12, f.calib_mag);
    io(13, f.gyro_bias_urad_s);
}

template <typename Io>
constexpr void describe(Io& io, PayloadOf<ButtonEvent> auto& b) {
    io(0, b.timestamp_us);
    io(8, b.button_id);
    io(9, b.state);
}

template <typename Io>
constexpr void describe(Io& io, PayloadOf<Heartbeat> auto& h) {
    io(0, h.timestamp_us);
    io(8, h.uptime_s);
    io(12, h.frames_sent);
    io(16, h.frames_dropped);
    io(20, h.rx_frames_ok);
    io(24, h.rx_frames_bad);
}

template <typename Io>
constexpr void describe(Io& io, PayloadOf<ErrorReport> auto& e) {
    io(0, e.timestamp_us);
    io(8, e.code);
    io(10, e.detail);
}

template <typename Io>
constexpr void describe(Io& io, PayloadOf<ConfigAck> auto& a) {
    io(0, a.request_seq);
    io(2, a.key);
    io(4, a.status);
    io(5, a.value);
}

template <typename Io>
constexpr void describe(Io&, PayloadOf<HelloRequest> auto&) {}  // empty payload

template <typename Io>
constexpr void describe(Io& io, PayloadOf<ConfigGet> auto& g) {
    io(0, g.key);
}

template <typename Io>
constexpr void describe(Io& io, PayloadOf<ConfigSet> auto& s) {
    io(0, s.key);
    io(2, s.value);
}

// ---- The walkers ---------------------------------------------------------------------------

// Encode: each field to its offset in the payload (the caller checked the span's size).
struct PayloadWriter {
    std::uint8_t* payload;
    template <typename T>
    void operator()(std::size_t offset, const T& field) const {
        FieldCodec<T>::put(payload + offset, field);
    }
};

// Decode: each field from its offset in the payload (the caller checked the span's size).
struct PayloadReader {
    const std::uint8_t* payload;
    template <typename T>
    void operator()(std::size_t offset, T& field) const {
        field = FieldCodec<T>::get(payload + offset);
    }
};

// Compile-time check of a description: PROTOCOL.md's payloads are packed, so every field must
// start where the one before it ended, and the last must end at the documented payload size.
struct LayoutCheck {
    std::size_t end = 0;
    bool packed = true;
    template <typename T>
    constexpr void operator()(std::size_t offset, const T&) {
        packed = packed && offset == end;
        end = offset + FieldCodec<T>::size;
    }
};

// ---- From a type byte to the message it names ----------------------------------------------

// Calls f(&Message::member) with the member of Message that holds a payload of `type`; false
// (f not called) for a type this version does not know. The one list of the known types.
template <typename F>
constexpr bool with_payload_member(MessageType type, F&& f) {
    switch (type) {
        case MessageType::Hello: f(&Message::hello); return true;
        case MessageType::Orientation: f(&Message::orientation); return true;
        case MessageType::RawImu: f(&Message::raw_imu); return true;
        case MessageType::FusionStatus: f(&Message::fusion_status); return true;
        case MessageType::ButtonEvent: f(&Message::button_event); return true;
        case MessageType::Heartbeat: f(&Message::heartbeat); return true;
        case MessageType::ErrorReport: f(&Message::error_report); return true;
        case MessageType::ConfigAck: f(&Message::config_ack); return true;
        case MessageType::HelloRequest: f(&Message::hello_request); return true;
        case MessageType::ConfigGet: f(&Message::config_get); return true;
        case MessageType::ConfigSet: f(&Message::config_set); return true;
    }
    return false;
}

// The payload struct a pointer to a member of Message points at.
template <typename MemberPointer>
struct PayloadTypeOf;
template <typename T>
struct PayloadTypeOf<T Message::*> {
    using type = T;
};
template <typename MemberPointer>
using PayloadType = typename PayloadTypeOf<MemberPointer>::type;

template <typename T>
constexpr bool layout_matches_protocol() {
    T message{};
    LayoutCheck check;
    describe(check, message);
    return check.packed && check.end == kPayloadSize<T>;
}

constexpr bool every_layout_matches_protocol() {
    bool ok = true;
    for (unsigned type = 0; type <= 0xFF; ++type) {
        with_payload_member(static_cast<MessageType>(type), [&](auto member) {
            ok = ok && layout_matches_protocol<PayloadType<decltype(member)>>();
        });
    }
    return ok;
}
static_assert(every_layout_matches_protocol(),
              "a payload description leaves a gap, overlaps, or does not end at its PROTOCOL.md size");

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
    return with_payload_member(static_cast<MessageType>(type), [](auto) {});
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
    std::size_t size = 0;
    with_payload_member(type, [&](auto member) { size = kPayloadSize<PayloadType<decltype(member)>>; });
    return size;
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
    bool equal = false;
    if (a.type == b.type) with_payload_member(a.type, [&](auto member) { equal = a.*member == b.*member; });
    return equal;
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
    const PayloadWriter writer{out.data()};
    with_payload_member(m.type, [&](auto member) { describe(writer, m.*member); });
    return {PayloadStatus::Ok, size};
}

PayloadStatus decode_payload(std::uint8_t type, std::span<const std::uint8_t> payload, Message& out) {
    if (!is_known_type(type)) return PayloadStatus::UnknownType;
    const auto message_type = static_cast<MessageType>(type);
    if (payload.size() < payload_size(message_type)) return PayloadStatus::BadLength;
    const PayloadReader reader{payload.data()};
    with_payload_member(message_type, [&](auto member) {
        PayloadType<decltype(member)> fields{};
        describe(reader, fields);
        out = fields;
    });
    return is_valid(out) ? PayloadStatus::Ok : PayloadStatus::BadValue;
}

}  // namespace glint::protocol
