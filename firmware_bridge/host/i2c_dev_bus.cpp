#include "firmware_bridge/host/i2c_dev_bus.hpp"

#include <fcntl.h>
#include <linux/i2c-dev.h>
#include <linux/i2c.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace glint::host {

LinuxI2cBus::LinuxI2cBus(std::string device) : device_(std::move(device)) {}

LinuxI2cBus::~LinuxI2cBus() {
    if (fd_ >= 0) ::close(fd_);
}

bool LinuxI2cBus::ensure_open() {
    if (fd_ >= 0) return true;
    fd_ = ::open(device_.c_str(), O_RDWR | O_CLOEXEC);
    if (fd_ < 0) {
        last_error_ = device_ + ": cannot open: " + std::strerror(errno);
        return false;
    }
    return true;
}

firmware::I2cStatus LinuxI2cBus::fail(int err, const char* what, std::uint8_t address) {
    char addr[8];
    std::snprintf(addr, sizeof addr, "0x%02x", address);
    last_error_ = device_ + ": " + what + " at " + addr + ": " + std::strerror(err);
    if (err == ENXIO || err == EREMOTEIO) return firmware::I2cStatus::Nack;
    if (err == ENODEV || err == EBADF || err == EIO) {  // the adapter went away: reopen next time
        ::close(fd_);
        fd_ = -1;
    }
    return firmware::I2cStatus::BusError;
}

firmware::I2cStatus LinuxI2cBus::write_reg(std::uint8_t address, std::uint8_t reg, std::uint8_t value) {
    if (!ensure_open()) return firmware::I2cStatus::BusError;
    std::uint8_t data[2] = {reg, value};
    i2c_msg msg{address, 0, 2, data};
    i2c_rdwr_ioctl_data xfer{&msg, 1};
    if (ioctl(fd_, I2C_RDWR, &xfer) < 0) return fail(errno, "register write", address);
    return firmware::I2cStatus::Ok;
}

firmware::I2cStatus LinuxI2cBus::read_regs(std::uint8_t address, std::uint8_t first_reg, std::span<std::uint8_t> out) {
    if (!ensure_open()) return firmware::I2cStatus::BusError;
    std::uint8_t reg = first_reg;
    i2c_msg msgs[2] = {{address, 0, 1, &reg}, {address, I2C_M_RD, std::uint16_t(out.size()), out.data()}};
    i2c_rdwr_ioctl_data xfer{msgs, 2};
    if (ioctl(fd_, I2C_RDWR, &xfer) < 0) return fail(errno, "register read", address);
    return firmware::I2cStatus::Ok;
}

}  // namespace glint::host
