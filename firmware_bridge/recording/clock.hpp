// The clock a recorder stamps markers with and a player paces playback by. One interface, two
// implementations: SteadyClock (the appliance's CLOCK_MONOTONIC, real sleeps) for real use and
// VirtualClock (time moves only when told to) for tests and as-fast-as-possible replay.
#pragma once

#include <cstdint>

namespace glint::recording {

class Clock {
public:
    virtual ~Clock() = default;
    // Microseconds of this clock's timeline (SteadyClock: CLOCK_MONOTONIC).
    virtual std::uint64_t now_us() = 0;
    // Returns once now_us() >= t_us (at once when that time has passed).
    virtual void sleep_until_us(std::uint64_t t_us) = 0;
};

// CLOCK_MONOTONIC in microseconds: the same clock the host drivers stamp received bytes with,
// so record times and marker times of a live recording share one timeline.
class SteadyClock final : public Clock {
public:
    std::uint64_t now_us() override;
    void sleep_until_us(std::uint64_t t_us) override;
};

// A clock that stands still until sleep_until_us() or advance_us() moves it: sleeping is
// instantaneous, so a recorded-speed replay runs as fast as the CPU allows and is deterministic.
class VirtualClock final : public Clock {
public:
    explicit VirtualClock(std::uint64_t start_us = 0) : now_(start_us) {}
    std::uint64_t now_us() override { return now_; }
    void sleep_until_us(std::uint64_t t_us) override {
        if (t_us > now_) now_ = t_us;
    }
    void advance_us(std::uint64_t dt_us) { now_ += dt_us; }

private:
    std::uint64_t now_;
};

}  // namespace glint::recording
