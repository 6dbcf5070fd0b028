#include "firmware_bridge/host/orientation_history.hpp"

#include <algorithm>
#include <stdexcept>

#include "firmware_bridge/firmware/rotation.hpp"
#include "firmware_bridge/protocol/messages.hpp"

namespace glint::host {

glm::dquat to_glm(const firmware::Quatd& q) {
    const firmware::Quatd u = firmware::normalized(q);
    return {u.w, u.x, u.y, u.z};
}

glm::dquat to_glm(const protocol::Orientation& o) {
    return to_glm(firmware::Quatd{protocol::from_q30(o.w_q30), protocol::from_q30(o.x_q30), protocol::from_q30(o.y_q30),
                                  protocol::from_q30(o.z_q30)});
}

OrientationHistory::OrientationHistory(std::size_t capacity, std::int64_t max_gap_ns,
                                       std::int64_t max_hold_ns)
    : ring_(capacity), max_gap_ns_(max_gap_ns), max_hold_ns_(max_hold_ns) {
    if (capacity < 2) throw std::invalid_argument("OrientationHistory: capacity must be at least 2");
}

const OrientationSample& OrientationHistory::nth(std::size_t i) const {
    const std::size_t cap = ring_.size();
    return ring_[(head_ + cap - size_ + i) % cap];
}

bool OrientationHistory::push(const OrientationSample& sample) {
    if (size_ > 0 && sample.t_ns <= nth(size_ - 1).t_ns) return false;
    ring_[head_] = sample;
    head_ = (head_ + 1) % ring_.size();
    size_ = std::min(size_ + 1, ring_.size());
    return true;
}

std::optional<OrientationSample> OrientationHistory::newest() const {
    if (size_ == 0) return std::nullopt;
    return nth(size_ - 1);
}

std::optional<OrientationSample> OrientationHistory::oldest() const {
    if (size_ == 0) return std::nullopt;
    return nth(0);
}

HistoryAnswer OrientationHistory::at(std::int64_t t_ns) const {
    if (size_ == 0 || t_ns < nth(0).t_ns) return {std::nullopt, Lookup::BeforeFirst};
    const OrientationSample& last = nth(size_ - 1);
    if (t_ns >= last.t_ns) {
        if (t_ns == last.t_ns) return {last.world_from_sensor, Lookup::Exact};
        if (t_ns - last.t_ns <= max_hold_ns_) return {last.world_from_sensor, Lookup::AfterLast};
        return {std::nullopt, Lookup::AfterLast};
    }
    // Binary search for the first sample later than t (exists: t < last.t_ns).
    std::size_t lo = 0, hi = size_ - 1;
    while (lo < hi) {
        const std::size_t mid = (lo + hi) / 2;
        if (nth(mid).t_ns > t_ns) hi = mid; else lo = mid + 1;
    }
    const OrientationSample& b = nth(lo);
    const OrientationSample& a = nth(lo - 1);  // lo >= 1 because nth(0).t_ns <= t_ns
    if (a.t_ns == t_ns) return {a.world_from_sensor, Lookup::Exact};
    if (b.t_ns - a.t_ns > max_gap_ns_) return {std::nullopt, Lookup::Gap};
    const double f = static_cast<double>(t_ns - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
    return {glm::slerp(a.world_from_sensor, b.world_from_sensor, f), Lookup::Interpolated};
}

}  // namespace glint::host
