// A BNO055 wired straight to the appliance's I2C bus (boards without a microcontroller). The
// firmware's own BNO055 driver (firmware/bno055_imu.hpp: probe, mode switches with the
// datasheet's delays, re-probe after NACKs or a chip reset) runs on the appliance against an
// I2C bus: Linux's i2c-dev (i2c_dev_bus.hpp) in the appliance, the simulator's register-level
// chip model in tests. Samples are stamped with the appliance time of the register read (the
// chip has no clock of its own to map).
//
// Health: timeouts = polls whose transfer failed (NACK or bus error); reconnects = times the
// driver had to probe the chip again after it had been running (a reset, a NACK run, a bus
// that came back); last_error names the device and address.
#pragma once

#include <atomic>
#include <memory>
#include <thread>

#include "firmware_bridge/firmware/bno055_imu.hpp"
#include "firmware_bridge/host/i2c_dev_bus.hpp"
#include "firmware_bridge/host/orientation_source.hpp"

namespace glint::host {

struct I2cBno055Options {
    std::uint8_t address = 0x28;
    int rate_hz = 100;  // fusion output rate of the chip
    // Bus errors with this error text are reported; the I2C bus object gives it (may be null).
    std::function<std::string()> bus_error;
};

class I2cBno055Source : public OrientationSource {
public:
    // `bus` must outlive the source. Throws SourceError for an address other than 0x28/0x29 or
    // a rate outside 1..100 Hz.
    I2cBno055Source(std::string name, firmware::I2cBus& bus, I2cBno055Options options, recording::Clock& clock,
                    SourceOptions source_options = {});
    ~I2cBno055Source() override;

    void start() override;  // polls on a thread until stop()
    void stop() override;
    // Runs the poll loop on the calling thread until the clock reaches `end_us` (tests, on a
    // virtual clock: deterministic).
    void run_until(std::uint64_t end_us);

private:
    void poll_once();

    firmware::I2cBus& bus_;
    I2cBno055Options options_;
    firmware::Bno055Imu driver_;
    std::thread thread_;
    std::atomic<bool> stopping_{false};
    std::uint64_t next_us_ = 0;
    bool was_running_ = false;
    std::uint32_t probes_at_running_ = 0;
};

namespace detail {
struct LinuxI2cBusHolder {
    explicit LinuxI2cBusHolder(std::string device) : linux_bus(std::move(device)) {}
    LinuxI2cBus linux_bus;
};
}  // namespace detail

// The appliance's own: the BNO055 on /dev/i2c-N.
class LinuxBno055Source final : private detail::LinuxI2cBusHolder, public I2cBno055Source {
public:
    LinuxBno055Source(std::string name, std::string device, std::uint8_t address, recording::Clock& clock,
                      SourceOptions source_options = {});
};

}  // namespace glint::host
