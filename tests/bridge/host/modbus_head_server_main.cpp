// glint_test_modbus_head: the Modbus pan/tilt head simulator (modbus_head_sim.hpp) as a process,
// for CLI tests of the real driver: serves on 127.0.0.1 (a port the kernel chooses, printed as the
// first line of stdout), sweeps the azimuth 20 degrees a second and the elevation slowly, until
// SIGINT or SIGTERM or --seconds.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <thread>

#include "firmware_bridge/host/modbus_head_sim.hpp"

namespace {
std::atomic<bool> stop{false};
void on_signal(int) { stop = true; }
}  // namespace

int main(int argc, char** argv) {
    double seconds = 30;
    for (int i = 1; i < argc; ++i) {
        if (std::strcmp(argv[i], "--seconds") == 0 && i + 1 < argc) {
            seconds = std::atof(argv[++i]);
        } else {
            std::fprintf(stderr, "usage: glint_test_modbus_head [--seconds S]\n");
            return 2;
        }
    }
    std::signal(SIGINT, on_signal);
    std::signal(SIGTERM, on_signal);
    auto head = glint::host::ModbusHeadSimulator::tcp();
    std::printf("%d\n", head->port());
    std::fflush(stdout);
    const auto start = std::chrono::steady_clock::now();
    while (!stop) {
        const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (t > seconds) break;
        head->set_angles(std::fmod(20.0 * t, 360.0) - 180.0, 30.0 * std::sin(0.5 * t));
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return 0;
}
