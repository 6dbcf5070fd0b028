#include "firmware_bridge/host/orientation_source.hpp"

#include <utility>

namespace glint::host {

namespace {
constexpr std::int64_t kRateWindowNs = 1'000'000'000;
}

const char* link_state_name(LinkState state) {
    switch (state) {
        case LinkState::Stopped: return "stopped";
        case LinkState::Connecting: return "connecting";
        case LinkState::Streaming: return "streaming";
        case LinkState::Stalled: return "stalled";
        case LinkState::Disconnected: return "disconnected";
        case LinkState::Finished: return "finished";
    }
    return "unknown";
}

OrientationSource::OrientationSource(std::string name, recording::Clock& clock, SourceOptions options)
    : name_(std::move(name)),
      clock_(clock),
      options_(options),
      history_(options.history_capacity, options.max_gap_ns, options.max_hold_ns) {
    if (options.stall_after_ns <= 0) throw SourceError(name_ + ": the stall limit must be positive");
}

void OrientationSource::set_sample_callback(SampleCallback callback) {
    const std::lock_guard lock(mutex_);
    callback_ = std::move(callback);
}

HistoryAnswer OrientationSource::orientation_at(std::int64_t t_ns) const {
    const std::lock_guard lock(mutex_);
    return history_.at(t_ns);
}

std::optional<OrientationSample> OrientationSource::newest() const {
    const std::lock_guard lock(mutex_);
    return history_.newest();
}

bool OrientationSource::publish(OrientationSample s) {
    const std::int64_t now = now_ns();
    s.t_ns -= options_.latency_offset_ns;
    SampleCallback callback;
    {
        const std::lock_guard lock(mutex_);
        if (!history_.push(s)) {
            ++health_.frame_errors;
            health_.last_error = name_ + ": sample out of time order dropped";
            return false;
        }
        ++health_.samples;
        last_arrival_ns_ = now;
        stall_counted_ = false;
        recent_arrivals_ns_.push_back(now);
        while (!recent_arrivals_ns_.empty() && recent_arrivals_ns_.front() <= now - kRateWindowNs) {
            recent_arrivals_ns_.pop_front();
        }
        if (health_.state == LinkState::Connecting || health_.state == LinkState::Stalled) {
            health_.state = LinkState::Streaming;
        }
        callback = callback_;
    }
    if (callback) callback(s);
    return true;
}

void OrientationSource::edit_health(const std::function<void(LinkHealth&)>& edit) {
    const std::lock_guard lock(mutex_);
    edit(health_);
}

void OrientationSource::set_state(LinkState state) {
    const std::lock_guard lock(mutex_);
    if (state == LinkState::Connecting || state == LinkState::Disconnected) {
        // A new connection starts a new silence clock: the old link's age is not a stall.
        stall_counted_ = true;
    }
    health_.state = state;
}

void OrientationSource::note_error(std::string message) {
    const std::lock_guard lock(mutex_);
    health_.last_error = std::move(message);
}

LinkHealth OrientationSource::health() const {
    const std::int64_t now = now_ns();
    const std::lock_guard lock(mutex_);
    LinkHealth h = health_;
    std::size_t recent = 0;
    for (std::int64_t t : recent_arrivals_ns_) recent += (t > now - kRateWindowNs) ? 1 : 0;
    h.rate_hz = static_cast<double>(recent) * 1e9 / static_cast<double>(kRateWindowNs);
    h.last_sample_age_ns = last_arrival_ns_ < 0 ? -1 : now - last_arrival_ns_;
    if (h.state == LinkState::Streaming && h.last_sample_age_ns > options_.stall_after_ns) {
        h.state = LinkState::Stalled;
        if (!stall_counted_) {
            // Counted once per silence, whether the driver's loop or a health() reader sees it first.
            stall_counted_ = true;
            ++stalls_;
        }
    }
    h.stalls = stalls_;
    return h;
}

}  // namespace glint::host
