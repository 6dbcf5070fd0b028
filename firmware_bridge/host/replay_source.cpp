#include "firmware_bridge/host/replay_source.hpp"

#include <variant>

#include "firmware_bridge/host/sample_recording.hpp"

namespace glint::host {

namespace detail {
ShiftedClock::ShiftedClock(ReplayPacing pacing) {
    if (pacing == ReplayPacing::Fast)
        virtual_ = std::make_unique<recording::VirtualClock>(0);
    else
        steady_ = std::make_unique<recording::SteadyClock>();
}
}  // namespace detail

ReplaySource::ReplaySource(std::string name, const std::string& path, ReplayPacing pacing, SourceOptions options)
    : detail::ReplayClockHolder(pacing), OrientationSource(std::move(name), replay_clock, options) {
    try {
        reader_ = std::make_unique<recording::RecordingReader>(path);
    } catch (const std::exception& e) {
        throw SourceError(this->name() + ": " + e.what());
    }
}

ReplaySource::~ReplaySource() { stop(); }

void ReplaySource::start() {
    if (thread_.joinable()) return;
    stopping_ = false;
    thread_ = std::thread([this] { replay(); });
}

void ReplaySource::stop() {
    stopping_ = true;
    if (thread_.joinable()) thread_.join();
}

void ReplaySource::run_to_end() {
    stopping_ = false;
    replay();
}

BoardStatus ReplaySource::board_status() const {
    const std::lock_guard lock(mutex_);
    return status_;
}

std::vector<recording::ReadIssue> ReplaySource::file_issues() const {
    const std::lock_guard lock(mutex_);
    return issues_;
}

void ReplaySource::replay() {
    set_state(LinkState::Connecting);
    reader_->rewind();
    // A file of a source without a byte stream (I2C, Modbus) holds its published samples as
    // decoded messages: those are replayed as they are (sample_recording.hpp). A serial board's
    // decoded messages repeat its raw bytes, which are decoded again instead.
    const bool decoded_only = !recording::transport_has_byte_stream(reader_->header().transport);
    BoardStream stream([this](const OrientationSample& s) { publish(s); });
    stream.set_message_sink(message_sink_);
    bool aligned = false;
    while (!stopping_) {
        const std::optional<recording::Record> record = reader_->next();
        if (!record) break;
        const std::optional<std::uint64_t> t = recording::record_time_us(record->body);
        if (t) {
            if (!aligned) {
                replay_clock.align(*t);
                aligned = true;
            }
            replay_clock.sleep_until_us(*t);  // pacing: recorded speed, or instant on the virtual clock
        }
        if (decoded_only) {
            const auto* decoded = std::get_if<recording::DecodedMessageRecord>(&record->body);
            if (decoded && message_sink_) message_sink_(std::int64_t(decoded->host_time_us) * 1000, decoded->message);
            if (decoded && decoded->message.type == protocol::MessageType::Orientation)
                publish(sample_from_decoded(decoded->host_time_us, decoded->message.orientation));
            else if (std::holds_alternative<recording::StreamRestartRecord>(record->body))
                edit_health([](LinkHealth& h) { ++h.reconnects; });
            continue;
        }
        if (const auto* raw = std::get_if<recording::RawBytesRecord>(&record->body)) {
            if (raw->direction != recording::Direction::Received) continue;
            stream.feed(std::int64_t(raw->time_us) * 1000, raw->bytes);
            edit_health([&](LinkHealth& h) { stream.copy_counters(h); });
        } else if (const auto* restart = std::get_if<recording::StreamRestartRecord>(&record->body)) {
            stream.restart(std::int64_t(restart->time_us) * 1000, restart->reason.c_str());
            edit_health([](LinkHealth& h) { ++h.reconnects; });
        }
    }
    {
        const std::lock_guard lock(mutex_);
        status_ = stream.status();
        issues_ = reader_->issues();
    }
    if (!issues_.empty()) note_error(issues_.back().message);
    set_state(LinkState::Finished);
    finished_ = true;
}

}  // namespace glint::host
