// The sensor-board simulator on a pseudo-terminal: what `glint-sensor-sim` runs, usable
// in-process too (tests, or an appliance test harness):
//
//   glint::firmware::sim::SensorSimOptions options;      // defaults: BNO055, "kiosk", 200 Hz
//   options.pty_link = "/tmp/glint-imu";                  // optional symlink to the slave
//   glint::firmware::sim::SensorSim sim(options);        // throws on a bad trajectory or no pty
//   open(sim.port().c_str(), O_RDWR | O_NOCTTY);          // the appliance's serial driver
//   std::atomic<bool> stop{false};
//   std::thread t([&] { sim.run(stop); });                // until duration_s or stop
#pragma once

#include <atomic>
#include <memory>
#include <string>

#include "firmware_bridge/firmware/sim/sim_board.hpp"
#include "firmware_bridge/firmware/sim/trajectory.hpp"

namespace glint::firmware::sim {

enum class Pacing {
    Realtime,  // board clock = CLOCK_MONOTONIC since start: frames at their real rates
    Fast,      // virtual clock, as fast as the reader takes the frames (waits while the pty is full)
};

struct SensorSimOptions {
    SimBoardOptions board;
    std::string trajectory = "kiosk";  // built-in name, "builtin:NAME", or a trajectory file
    bool loop_trajectory = true;       // files: repeat after the last sample (built-ins always loop)
    std::string pty_link;              // empty: no symlink
    // "pty" (default): a new pseudo-terminal; anything else: a serial device opened at `baud`.
    std::string port = "pty";
    int baud = 115200;
    double duration_s = 0;             // board-clock seconds to run; 0 = until stopped
    Pacing pacing = Pacing::Realtime;
};

// "static", "builtin:static" -> the built-in; anything else is read as a file (errors name the
// file and line).
Trajectory load_trajectory(const std::string& spec);

class SensorSim {
public:
    explicit SensorSim(SensorSimOptions options);
    ~SensorSim();

    const std::string& port() const { return uart_->port(); }  // e.g. /dev/pts/7, /dev/ttyUSB0
    const std::string& link() const { return pty_ ? pty_->link_path() : no_link_; }
    // Starts the firmware (Hello with seq 0) and runs until duration_s or `stop` becomes true.
    // Returns within about 100 ms of `stop` being set.
    void run(const std::atomic<bool>& stop);
    std::uint64_t now_us() const { return clock_->now_us(); }
    const FirmwareStats& stats() { return board_->firmware().stats(); }

private:
    SensorSimOptions options_;
    Trajectory trajectory_;
    std::unique_ptr<FdUart> uart_;
    PtyUart* pty_ = nullptr;  // uart_ when it is a pty
    std::string no_link_;
    std::unique_ptr<RealtimeClock> realtime_clock_;
    std::unique_ptr<VirtualClock> virtual_clock_;
    Clock* clock_ = nullptr;
    std::unique_ptr<SimBoard> board_;
};

}  // namespace glint::firmware::sim
