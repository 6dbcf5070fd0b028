#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "firmware_bridge/host/board_clock.hpp"

namespace glint::host {
namespace {

// A board whose clock runs `ppm` fast, sampled at 100 Hz, received after a delay of 0.2-5 ms
// with a 30 ms spike every ~2 s.
struct Link {
    double ppm;
    std::int64_t host_at_reset_ns;
    std::mt19937_64 rng{42};
    std::int64_t true_host_ns(std::uint64_t board_us) const {
        return host_at_reset_ns + std::int64_t(std::llround(double(board_us) * 1000.0 / (1 + ppm * 1e-6)));
    }
    std::int64_t delay_ns() {
        const std::uint64_t r = rng();
        if (r % 200 == 0) return 30'000'000;
        return 200'000 + std::int64_t(r % 4'800'000);
    }
};

TEST(BoardClock, TracksDriftOnTheLowerEnvelopeOfJitteredDelays) {
    Link link{50.0, 7'000'000'000};
    BoardClock clock;
    double worst_after_settling_ns = 0;
    for (std::uint64_t b = 0; b <= 60'000'000; b += 10'000) {
        clock.observe(b, link.true_host_ns(b) + link.delay_ns());
        if (b >= 30'000'000) {
            // Mapped time = true time + the smallest delay seen (~0.2 ms), within a little more.
            const double err = double(*clock.to_host_ns(b) - link.true_host_ns(b)) - 200'000.0;
            worst_after_settling_ns = std::max(worst_after_settling_ns, std::abs(err));
        }
    }
    EXPECT_NEAR(clock.drift_ppm(), 50.0, 3.0);
    EXPECT_LT(worst_after_settling_ns, 300'000.0);  // 0.3 ms, against delays of up to 30 ms
}

TEST(BoardClock, ANegativeDriftIsTrackedToo) {
    Link link{-80.0, 1'000'000'000};
    BoardClock clock;
    for (std::uint64_t b = 0; b <= 40'000'000; b += 10'000) clock.observe(b, link.true_host_ns(b) + link.delay_ns());
    EXPECT_NEAR(clock.drift_ppm(), -80.0, 3.0);
}

TEST(BoardClock, ABoardResetStartsANewEstimate) {
    Link link{20.0, 5'000'000'000};
    BoardClock clock;
    for (std::uint64_t b = 0; b <= 10'000'000; b += 10'000) clock.observe(b, link.true_host_ns(b) + 300'000);
    // The board resets 12 s after the first: its clock restarts at 0, host time moves on.
    const std::int64_t reset_host = link.true_host_ns(12'000'000);
    EXPECT_FALSE(clock.observe(0, reset_host + 300'000));
    EXPECT_EQ(clock.resets(), 1u);
    for (std::uint64_t b = 10'000; b <= 2'000'000; b += 10'000)
        EXPECT_TRUE(clock.observe(b, reset_host + std::int64_t(b) * 1000 + 300'000));
    EXPECT_NEAR(double(*clock.to_host_ns(1'000'000)), double(reset_host + 1'000'000'000 + 300'000), 1000.0);
}

TEST(BoardClock, NothingToMapBeforeTheFirstSample) {
    BoardClock clock;
    EXPECT_FALSE(clock.to_host_ns(5));
    clock.observe(1000, 2'000'000);
    EXPECT_EQ(*clock.to_host_ns(1000), 2'000'000);
    EXPECT_EQ(*clock.to_host_ns(2000), 3'000'000);  // no rate yet: 1:1
}

}  // namespace
}  // namespace glint::host
