// Sensor-board simulator on a pty: see sensor_sim.hpp.
#include "firmware_bridge/firmware/sim/sensor_sim.hpp"

#include <algorithm>

namespace glint::firmware::sim {

Trajectory load_trajectory(const std::string& spec) {
    const std::string prefix = "builtin:";
    if (spec.rfind(prefix, 0) == 0) return Trajectory::builtin(spec.substr(prefix.size()));
    const auto names = Trajectory::builtin_names();
    if (std::find(names.begin(), names.end(), spec) != names.end()) return Trajectory::builtin(spec);
    return Trajectory::load(spec);
}

SensorSim::SensorSim(SensorSimOptions options)
    : options_(std::move(options)), trajectory_(load_trajectory(options_.trajectory)) {
    if (options_.loop_trajectory) trajectory_.set_loop(true);
    if (options_.port == "pty") {
        auto pty = std::make_unique<PtyUart>(options_.pty_link);
        pty_ = pty.get();
        uart_ = std::move(pty);
    } else {
        if (!options_.pty_link.empty()) throw std::runtime_error("--pty-link needs --port pty");
        uart_ = std::make_unique<SerialDeviceUart>(options_.port, options_.baud);
    }
    if (options_.pacing == Pacing::Realtime) {
        realtime_clock_ = std::make_unique<RealtimeClock>(uart_->fd());
        clock_ = realtime_clock_.get();
    } else {
        virtual_clock_ = std::make_unique<VirtualClock>();
        clock_ = virtual_clock_.get();
    }
    board_ = std::make_unique<SimBoard>(trajectory_, options_.board, *uart_, *clock_);
}

SensorSim::~SensorSim() = default;

void SensorSim::run(const std::atomic<bool>& stop) {
    const auto end_us = options_.duration_s > 0
                            ? static_cast<std::uint64_t>(options_.duration_s * 1e6)
                            : UINT64_MAX;
    Firmware& fw = board_->firmware();
    fw.start();
    while (!stop.load() && clock_->now_us() < end_us) {
        if (options_.pacing == Pacing::Fast) {
            // Back-pressure instead of real time: while a quarter of the transmit buffer waits,
            // let the reader catch up (checking `stop` every 100 ms).
            while (!stop.load() && uart_->flush() > 4096) uart_->wait_drain(100);
        }
        fw.poll();
        uart_->flush();
        // Real time: sleep in slices of at most 100 ms so `stop` is noticed.
        const std::uint64_t wake = std::min(fw.next_wake_us(), clock_->now_us() + 100'000);
        clock_->wait_until_us(std::min(wake, end_us));
    }
    // Give a reader up to a second to take the last frames.
    for (int i = 0; i < 10 && uart_->flush() > 0; ++i) uart_->wait_drain(100);
}

}  // namespace glint::firmware::sim
