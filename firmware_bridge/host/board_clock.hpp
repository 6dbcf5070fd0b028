// Maps the sensor board's clock (µs since board reset) to the appliance's CLOCK_MONOTONIC (ns)
// with a drift-tracking estimate.
//
// Every received orientation gives a pair (board time b, host receive time h). h = b mapped +
// transport delay, and the delay is never negative but varies (UART line time, USB polling,
// scheduling: 0.2 to 5 ms, sometimes 30 ms). So the estimate follows the lower envelope: the
// samples are grouped into buckets of `bucket_us` board time, the one with the smallest offset
// h - b per bucket is kept (the least-delayed sample), and a line fitted through the last
// `window_buckets` minima gives the rate (drift) and the offset. A mapped time is therefore
// "board time as the host would see it with the least delay observed": the fixed remainder of
// the transport latency belongs to the source's latency offset (orientation_source.hpp).
//
// A board reset (its clock going backwards, or the caller's restart()) starts a new estimate.
#pragma once

#include <cstdint>
#include <deque>
#include <optional>

namespace glint::host {

struct BoardClockOptions {
    std::uint64_t bucket_us = 1'000'000;  // board time per envelope bucket
    std::size_t window_buckets = 30;      // buckets the line is fitted over (30 s)
};

class BoardClock {
public:
    explicit BoardClock(BoardClockOptions options = {});

    // One received sample. Returns false when the board clock went backwards (a reset): the
    // estimate restarted from this sample.
    bool observe(std::uint64_t board_us, std::int64_t host_ns);

    // Appliance time of a board instant; nullopt before the first observation.
    std::optional<std::int64_t> to_host_ns(std::uint64_t board_us) const;

    double drift_ppm() const { return drift_ppm_; }         // board clock rate vs. host, ppm
    std::int64_t last_residual_ns() const { return residual_ns_; }  // last sample's delay above the envelope
    std::uint64_t resets() const { return resets_; }
    void restart();  // forget everything (e.g. the port was reopened to a possibly other board)

private:
    struct Bucket {
        std::uint64_t index = 0;
        std::uint64_t board_us = 0;
        std::int64_t offset_ns = 0;  // host_ns - board_us * 1000, the smallest of the bucket
    };
    void refit();

    BoardClockOptions options_;
    std::deque<Bucket> buckets_;
    std::optional<std::uint64_t> last_board_us_;
    // host = board * 1000 * (1 + rate) + intercept, relative to ref_board_us_ for precision.
    std::uint64_t ref_board_us_ = 0;
    double rate_ = 0;
    double intercept_ns_ = 0;
    double drift_ppm_ = 0;
    std::int64_t residual_ns_ = 0;
    std::uint64_t resets_ = 0;
};

}  // namespace glint::host
