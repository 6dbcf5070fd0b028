// Text forms for the tool and reports.
#include "firmware_bridge/recording/text.hpp"

#include <cinttypes>
#include <cstdio>

namespace glint::recording {
namespace {

std::string format(const char* fmt, auto... args) {
    char buf[256];
    std::snprintf(buf, sizeof buf, fmt, args...);
    return buf;
}

std::string vec3(const std::array<std::int32_t, 3>& v) {
    return format("(%" PRId32 ", %" PRId32 ", %" PRId32 ")", v[0], v[1], v[2]);
}

}  // namespace

std::string printable(const std::string& text) {
    std::string out;
    for (const char c : text) {
        const auto u = static_cast<unsigned char>(c);
        if (u < 0x20 || u >= 0x7F || c == '\\') out += format("\\x%02x", static_cast<unsigned>(u));
        else out += c;
    }
    return out;
}

std::string hex_bytes(std::span<const std::uint8_t> bytes, std::size_t max_bytes) {
    std::string out;
    const std::size_t n = std::min(bytes.size(), max_bytes);
    for (std::size_t i = 0; i < n; ++i) out += format(i == 0 ? "%02x" : " %02x", static_cast<unsigned>(bytes[i]));
    if (n < bytes.size()) out += " ...";
    return out;
}

std::string describe_message(const protocol::Message& m) {
    using protocol::MessageType;
    const std::string name = protocol::type_name(static_cast<std::uint8_t>(m.type));
    switch (m.type) {
    case MessageType::Hello:
        return name + format(" protocol %u.%u firmware %u.%u.%u board_id=0x%08" PRIX32 " capabilities=0x%02" PRIX32
                             " buttons=%u",
                             m.hello.protocol_major, m.hello.protocol_minor, m.hello.firmware_major,
                             m.hello.firmware_minor, m.hello.firmware_patch, m.hello.board_id, m.hello.capabilities,
                             m.hello.button_count);
    case MessageType::Orientation:
        return name + format(" board_t=%" PRIu64 "us q=(%.9f, %.9f, %.9f, %.9f)", m.orientation.timestamp_us,
                             protocol::from_q30(m.orientation.w_q30), protocol::from_q30(m.orientation.x_q30),
                             protocol::from_q30(m.orientation.y_q30), protocol::from_q30(m.orientation.z_q30));
    case MessageType::RawImu:
        return name + format(" board_t=%" PRIu64 "us", m.raw_imu.timestamp_us) +
               " gyro_urad_s=" + vec3(m.raw_imu.gyro_urad_s) + " accel_um_s2=" + vec3(m.raw_imu.accel_um_s2) +
               " mag_nT=" + vec3(m.raw_imu.mag_nt) + format(" valid=0x%x", static_cast<unsigned>(m.raw_imu.valid));
    case MessageType::FusionStatus:
        return name + format(" board_t=%" PRIu64 "us mode=%u calib sys %u gyro %u accel %u mag %u",
                             m.fusion_status.timestamp_us, static_cast<unsigned>(m.fusion_status.mode),
                             m.fusion_status.calib_system, m.fusion_status.calib_gyro, m.fusion_status.calib_accel,
                             m.fusion_status.calib_mag) +
               " gyro_bias_urad_s=" + vec3(m.fusion_status.gyro_bias_urad_s);
    case MessageType::ButtonEvent:
        return name + format(" board_t=%" PRIu64 "us button=%u %s", m.button_event.timestamp_us,
                             m.button_event.button_id,
                             m.button_event.state == protocol::ButtonState::Pressed ? "pressed" : "released");
    case MessageType::Heartbeat:
        return name + format(" board_t=%" PRIu64 "us uptime=%" PRIu32 "s sent=%" PRIu32 " dropped=%" PRIu32
                             " rx_ok=%" PRIu32 " rx_bad=%" PRIu32,
                             m.heartbeat.timestamp_us, m.heartbeat.uptime_s, m.heartbeat.frames_sent,
                             m.heartbeat.frames_dropped, m.heartbeat.rx_frames_ok, m.heartbeat.rx_frames_bad);
    case MessageType::ErrorReport:
        return name + format(" board_t=%" PRIu64 "us code=%u detail=0x%" PRIX32, m.error_report.timestamp_us,
                             m.error_report.code, m.error_report.detail);
    case MessageType::ConfigAck:
        return name + format(" request_seq=%u key=%u status=%u value_type=%u bits=0x%08" PRIX32,
                             m.config_ack.request_seq, m.config_ack.key, static_cast<unsigned>(m.config_ack.status),
                             static_cast<unsigned>(m.config_ack.value.type), m.config_ack.value.bits);
    case MessageType::HelloRequest: return name;
    case MessageType::ConfigGet: return name + format(" key=%u", m.config_get.key);
    case MessageType::ConfigSet:
        return name + format(" key=%u value_type=%u bits=0x%08" PRIX32, m.config_set.key,
                             static_cast<unsigned>(m.config_set.value.type), m.config_set.value.bits);
    }
    return name;
}

std::string describe_record(const RecordBody& body, std::size_t max_hex) {
    if (const auto* r = std::get_if<RawBytesRecord>(&body))
        return format("raw_bytes %s t=%" PRIu64 "us stream_offset=%" PRIu64 " %zu bytes: ",
                      r->direction == Direction::Received ? "rx" : "tx", r->time_us, r->stream_offset,
                      r->bytes.size()) +
               hex_bytes(r->bytes, max_hex);
    if (const auto* r = std::get_if<DecodedMessageRecord>(&body))
        return format("decoded_message t=%" PRIu64 "us stream_offset=%" PRIu64 " seq=%u ", r->host_time_us,
                      r->stream_offset, r->seq) +
               describe_message(r->message);
    if (const auto* r = std::get_if<GpioEventRecord>(&body))
        return format("gpio_event t=%" PRIu64 "us line=%" PRIu32 " %s chip=\"", r->time_us, r->line,
                      r->edge == Edge::Rising ? "rising" : "falling") +
               printable(r->chip) + "\"";
    if (const auto* r = std::get_if<MarkerRecord>(&body))
        return format("marker t=%" PRIu64 "us \"", r->time_us) + printable(r->text) + "\"";
    if (const auto* r = std::get_if<StreamRestartRecord>(&body))
        return format("stream_restart t=%" PRIu64 "us \"", r->time_us) + printable(r->reason) + "\"";
    const auto& u = std::get<UnknownRecord>(body);
    return format("unknown type=%u flags=0x%04x %zu bytes: ", u.type, u.flags, u.payload.size()) +
           hex_bytes(u.payload, max_hex);
}

std::string describe_stats(const protocol::DecoderStats& s) {
    std::string out;
    auto row = [&](const char* name, std::uint64_t v) { out += format("  %-20s %" PRIu64 "\n", name, v); };
    row("bytes_in", s.bytes_in);
    row("bytes_accepted", s.bytes_accepted);
    row("bytes_discarded", s.bytes_discarded);
    row("idle_delimiters", s.idle_delimiters);
    row("frames_ok", s.frames_ok);
    row("cobs_errors", s.cobs_errors);
    row("too_short", s.too_short);
    row("crc_errors", s.crc_errors);
    row("version_mismatches", s.version_mismatches);
    row("unknown_types", s.unknown_types);
    row("bad_lengths", s.bad_lengths);
    row("bad_values", s.bad_values);
    row("oversize_frames", s.oversize_frames);
    row("truncated_at_end", s.truncated_at_end);
    row("extended_payloads", s.extended_payloads);
    row("lost_frames", s.lost_frames);
    row("sender_restarts", s.sender_restarts);
    return out;
}

}  // namespace glint::recording
