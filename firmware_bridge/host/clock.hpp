// The clock the appliance side keeps time on: sensor drivers, replays and camera sources share
// one timeline (the appliance's CLOCK_MONOTONIC, or a virtual clock in tests and offline runs).
// It is the recording library's clock (recording/clock.hpp); this is its name for consumers of
// the host, who need not know where it lives.
#pragma once

#include "firmware_bridge/recording/clock.hpp"

namespace glint::host {

using Clock = recording::Clock;
using SteadyClock = recording::SteadyClock;
using VirtualClock = recording::VirtualClock;

}  // namespace glint::host
