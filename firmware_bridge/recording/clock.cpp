// SteadyClock on CLOCK_MONOTONIC; sleeps use clock_nanosleep with an absolute deadline so that
// pacing does not accumulate the overshoot of each sleep.
#include "firmware_bridge/recording/clock.hpp"

#include <cerrno>
#include <ctime>

namespace glint::recording {

std::uint64_t SteadyClock::now_us() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000u + static_cast<std::uint64_t>(ts.tv_nsec) / 1000u;
}

void SteadyClock::sleep_until_us(std::uint64_t t_us) {
    timespec deadline{};
    deadline.tv_sec = static_cast<time_t>(t_us / 1'000'000u);
    deadline.tv_nsec = static_cast<long>((t_us % 1'000'000u) * 1000u);
    // EINTR (a signal) only shortens the sleep; go back to sleep until the deadline.
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &deadline, nullptr) == EINTR) {
    }
}

}  // namespace glint::recording
