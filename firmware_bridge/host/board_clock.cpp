#include "firmware_bridge/host/board_clock.hpp"

#include <cmath>
#include <stdexcept>

namespace glint::host {

BoardClock::BoardClock(BoardClockOptions options) : options_(options) {
    if (options_.bucket_us == 0 || options_.window_buckets < 2)
        throw std::invalid_argument("BoardClock: bucket_us must be > 0 and window_buckets >= 2");
}

void BoardClock::restart() {
    buckets_.clear();
    last_board_us_.reset();
    rate_ = 0;
    intercept_ns_ = 0;
    drift_ppm_ = 0;
    residual_ns_ = 0;
}

bool BoardClock::observe(std::uint64_t board_us, std::int64_t host_ns) {
    bool continuous = true;
    if (last_board_us_ && board_us < *last_board_us_) {
        restart();
        ++resets_;
        continuous = false;
    }
    last_board_us_ = board_us;
    const std::int64_t offset = host_ns - std::int64_t(board_us) * 1000;
    const std::uint64_t index = board_us / options_.bucket_us;
    if (buckets_.empty() || buckets_.back().index != index) {
        buckets_.push_back({index, board_us, offset});
        while (buckets_.size() > options_.window_buckets) buckets_.pop_front();
    } else if (offset < buckets_.back().offset_ns) {
        buckets_.back().board_us = board_us;
        buckets_.back().offset_ns = offset;
    }
    refit();
    const std::optional<std::int64_t> mapped = to_host_ns(board_us);
    residual_ns_ = mapped ? host_ns - *mapped : 0;
    return continuous;
}

void BoardClock::refit() {
    ref_board_us_ = buckets_.back().board_us;
    if (buckets_.size() < 3) {
        // Too little span for a rate: the offset of the least-delayed sample so far.
        std::int64_t best = buckets_.front().offset_ns;
        for (const Bucket& b : buckets_) best = std::min(best, b.offset_ns);
        rate_ = 0;
        intercept_ns_ = double(best) + double(ref_board_us_) * 1000.0;
        drift_ppm_ = 0;
        return;
    }
    // Least squares of offset against board time over the bucket minima (the newest bucket may
    // still be filling; its minimum so far is an upper bound and is left out).
    const std::size_t n = buckets_.size() - 1;
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (std::size_t k = 0; k < n; ++k) {
        const double x = (double(buckets_[k].board_us) - double(ref_board_us_)) * 1e-6;  // s
        const double y = double(buckets_[k].offset_ns);
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    const double den = double(n) * sxx - sx * sx;
    const double slope = den > 0 ? (double(n) * sxy - sx * sy) / den : 0;  // ns of offset per s of board time
    double c = (sy - slope * sx) / double(n);                              // offset at ref_board_us_
    // The line must stay under every minimum, the newest included: lower it to the envelope.
    for (const Bucket& b : buckets_) {
        const double x = (double(b.board_us) - double(ref_board_us_)) * 1e-6;
        c = std::min(c, double(b.offset_ns) - slope * x);
    }
    rate_ = slope * 1e-9;  // dimensionless
    drift_ppm_ = -slope * 1e-3;  // offset falling with board time = board clock running fast
    intercept_ns_ = c + double(ref_board_us_) * 1000.0;
}

std::optional<std::int64_t> BoardClock::to_host_ns(std::uint64_t board_us) const {
    if (buckets_.empty()) return std::nullopt;
    const double dx_us = double(board_us) - double(ref_board_us_);
    // host = board*1000 + offset(board), offset linear in board time.
    const double host = intercept_ns_ + dx_us * 1000.0 + rate_ * dx_us * 1000.0;
    return std::int64_t(std::llround(host));
}

}  // namespace glint::host
