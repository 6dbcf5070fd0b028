#include "firmware_bridge/host/sample_recording.hpp"

#include <cmath>

#include "firmware_bridge/host/serial_source.hpp"

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

namespace {
recording::RecorderOptions recordable(const SourceSpec& spec) {
    if (std::optional<recording::RecorderOptions> o = recording_options_for(spec)) return *o;
    throw SourceError(spec.text + ": a replay is a recording already; it is not recorded again");
}
}  // namespace

SensorRecording::SensorRecording(const std::string& path, const SourceSpec& spec, recording::Clock& clock)
    : recorder_(path, recordable(spec), clock), serial_(spec.kind == SourceKind::Serial) {}

void SensorRecording::attach(OrientationSource& source) {
    if (serial_) {
        static_cast<SerialSource&>(source).set_recorder(&recorder_);
        return;
    }
    const std::lock_guard lock(mutex_);
    samples_.emplace(recorder_, source.options().latency_offset_ns);
}

void SensorRecording::sample(const OrientationSample& s) {
    const std::lock_guard lock(mutex_);
    if (samples_) samples_->record(s);  // the recorder keeps its own error
}

bool SensorRecording::close() {
    {
        const std::lock_guard lock(mutex_);
        samples_.reset();
    }
    return recorder_.close();
}

OrientationSample sample_from_decoded(std::uint64_t host_time_us, const protocol::Orientation& o) {
    OrientationSample s;
    s.t_ns = static_cast<std::int64_t>(host_time_us) * 1000;
    s.board_us = o.timestamp_us;
    s.world_from_sensor = to_glm(o);
    return s;
}

}  // namespace glint::host
