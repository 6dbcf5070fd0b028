#include "firmware_bridge/host/sample_recording.hpp"

#include <cmath>

#include "firmware_bridge/firmware/rotation.hpp"

namespace glint::host {

bool SampleRecorder::record(const OrientationSample& s) {
    const std::int64_t published_ns = s.t_ns + latency_offset_ns_;
    if (published_ns < 0) return recorder_.ok();  // before the clock's zero: no time to write
    protocol::Orientation o{};
    o.timestamp_us = s.board_us;
    o.w_q30 = protocol::to_q30(s.world_from_sensor.w);
    o.x_q30 = protocol::to_q30(s.world_from_sensor.x);
    o.y_q30 = protocol::to_q30(s.world_from_sensor.y);
    o.z_q30 = protocol::to_q30(s.world_from_sensor.z);
    // Rounded to the nearest microsecond, the file's unit: a replay's time is within 0.5 us.
    const auto host_us = static_cast<std::uint64_t>((published_ns + 500) / 1000);
    return recorder_.on_message(host_us, 0, seq_++, protocol::Message(o));
}

std::optional<recording::RecorderOptions> recording_options_for(const SourceSpec& spec) {
    switch (spec.kind) {
        case SourceKind::Serial:
            return recording::serial_board_recording(spec.path, std::uint32_t(spec.baud));
        case SourceKind::I2c:
            return recording::decoded_sample_recording(recording::Transport::I2c, spec.text);
        case SourceKind::ModbusTcp:
        case SourceKind::ModbusRtu:
            return recording::decoded_sample_recording(recording::Transport::Modbus, spec.text);
        case SourceKind::Replay:
            return std::nullopt;
    }
    return std::nullopt;
}

OrientationSample sample_from_decoded(std::uint64_t host_time_us, const protocol::Orientation& o) {
    OrientationSample s;
    s.t_ns = static_cast<std::int64_t>(host_time_us) * 1000;
    s.board_us = o.timestamp_us;
    s.world_from_sensor = to_glm(firmware::Quatd{protocol::from_q30(o.w_q30), protocol::from_q30(o.x_q30),
                                                 protocol::from_q30(o.y_q30), protocol::from_q30(o.z_q30)});
    return s;
}

}  // namespace glint::host
