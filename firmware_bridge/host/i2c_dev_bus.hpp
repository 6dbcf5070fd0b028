// The firmware HAL's I2C master (firmware/hal.hpp) on Linux's i2c-dev (/dev/i2c-N): one
// I2C_RDWR ioctl per transaction, a register read as write + repeated start + read, so the
// firmware's own BNO055 driver runs unchanged on the appliance (i2c_bno055_source.hpp).
// The device is opened lazily and reopened after an error that means it went away.
#pragma once

#include <cstdint>
#include <string>

#include "firmware_bridge/firmware/hal.hpp"

namespace glint::host {

class LinuxI2cBus final : public firmware::I2cBus {
public:
    explicit LinuxI2cBus(std::string device);  // e.g. "/dev/i2c-1"; nothing is opened yet
    ~LinuxI2cBus();
    LinuxI2cBus(const LinuxI2cBus&) = delete;
    LinuxI2cBus& operator=(const LinuxI2cBus&) = delete;

    // NACK (ENXIO, EREMOTEIO: nobody answered at that address) -> Nack; anything else, including
    // a device that cannot be opened, -> BusError. last_error() says which and why.
    firmware::I2cStatus write_reg(std::uint8_t address, std::uint8_t reg, std::uint8_t value) override;
    firmware::I2cStatus read_regs(std::uint8_t address, std::uint8_t first_reg, std::span<std::uint8_t> out) override;

    const std::string& device() const { return device_; }
    const std::string& last_error() const { return last_error_; }

private:
    bool ensure_open();
    firmware::I2cStatus fail(int err, const char* what, std::uint8_t address);

    std::string device_;
    int fd_ = -1;
    std::string last_error_;
};

}  // namespace glint::host
