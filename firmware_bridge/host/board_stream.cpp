#include "firmware_bridge/host/board_stream.hpp"

#include "firmware_bridge/recording/player.hpp"

namespace glint::host {

BoardStream::BoardStream(SampleSink on_sample, BoardClockOptions clock_options)
    : on_sample_(std::move(on_sample)), clock_(clock_options) {}

void BoardStream::feed(std::int64_t host_ns, std::span<const std::uint8_t> bytes) {
    // Recordings keep receive times in µs: live and replayed streams use the same µs times, so a
    // replay reproduces every mapped sample time exactly.
    const std::uint64_t host_us = std::uint64_t(host_ns / 1000);
    host_ns = std::int64_t(host_us) * 1000;
    if (recorder_) recorder_->on_bytes(host_us, bytes);
    decoder_.feed_all(bytes, [&](const protocol::FrameEvent& e) {
        if (recorder_) recorder_->on_sample(host_us, e);
        if (e.status != protocol::FrameStatus::Ok) return;
        const protocol::Message& m = e.message;
        switch (m.type) {
            case protocol::MessageType::Orientation: {
                const protocol::Orientation& o = m.orientation;
                clock_.observe(o.timestamp_us, host_ns);
                OrientationSample s;
                s.board_us = o.timestamp_us;
                s.world_from_sensor = to_glm(o);
                chunk_samples_.push_back(s);
                break;
            }
            case protocol::MessageType::Hello:
                status_.hello = m.hello;
                break;
            case protocol::MessageType::FusionStatus:
                status_.fusion = m.fusion_status;
                break;
            case protocol::MessageType::Heartbeat:
                status_.heartbeat = m.heartbeat;
                break;
            case protocol::MessageType::ErrorReport:
                status_.last_error = m.error_report;
                break;
            default:
                break;
        }
        if (on_message_) on_message_(host_ns, m);
    });
    // The orientations of one read are timed together, with the estimate that has seen all of
    // them: frames that arrive in one chunk (USB packets, a busy reader) stay in board-time order
    // and spacing instead of each pulling the envelope down past the one before.
    for (OrientationSample& s : chunk_samples_) {
        s.t_ns = *clock_.to_host_ns(s.board_us);
        if (last_published_ns_ && s.t_ns <= *last_published_ns_) {
            ++untimed_;
            continue;
        }
        last_published_ns_ = s.t_ns;
        on_sample_(s);
    }
    chunk_samples_.clear();
}

void BoardStream::restart(std::int64_t host_ns, const char* reason) {
    recording::accumulate(before_restarts_, decoder_.stats());
    decoder_.reset();
    clock_.restart();
    last_published_ns_.reset();
    if (recorder_) recorder_->on_stream_restart(std::uint64_t(host_ns / 1000), reason);
}

protocol::DecoderStats BoardStream::total() const {
    protocol::DecoderStats t = before_restarts_;
    recording::accumulate(t, decoder_.stats());
    return t;
}

std::uint64_t BoardStream::crc_errors() const { return total().crc_errors; }

std::uint64_t BoardStream::frame_errors() const {
    const protocol::DecoderStats t = total();
    return t.cobs_errors + t.too_short + t.version_mismatches + t.unknown_types + t.bad_lengths + t.bad_values +
           t.oversize_frames + t.truncated_at_end;
}

std::uint64_t BoardStream::lost_frames() const { return total().lost_frames; }
std::uint64_t BoardStream::frames_ok() const { return total().frames_ok; }

}  // namespace glint::host

namespace glint::host {

void BoardStream::copy_counters(LinkHealth& h) const {
    const protocol::DecoderStats t = total();
    h.crc_errors = t.crc_errors;
    h.frame_errors = frame_errors();
    h.lost_frames = t.lost_frames;
    h.untimed_samples = untimed_;
    h.clock_drift_ppm = clock_.drift_ppm();
}

}  // namespace glint::host
