// Simulated I2C bus: see sim_i2c_bus.hpp.
#include "firmware_bridge/firmware/sim/sim_i2c_bus.hpp"

namespace glint::firmware::sim {

I2cDevice* SimI2cBus::device_at(std::uint8_t address, std::uint64_t now_us) {
    ++transfers_;
    for (const Window& w : windows_) {
        if (w.address == address && now_us >= w.start_us && now_us < w.end_us) return nullptr;
    }
    const auto it = devices_.find(address);
    return it == devices_.end() ? nullptr : it->second;
}

I2cStatus SimI2cBus::write_reg(std::uint8_t address, std::uint8_t reg, std::uint8_t value) {
    const std::uint64_t now = clock_.now_us();
    I2cDevice* device = device_at(address, now);
    const I2cStatus s = device == nullptr ? I2cStatus::Nack : device->write_reg(reg, value, now);
    if (s != I2cStatus::Ok) ++nacks_;
    return s;
}

I2cStatus SimI2cBus::read_regs(std::uint8_t address, std::uint8_t first_reg, std::span<std::uint8_t> out) {
    const std::uint64_t now = clock_.now_us();
    I2cDevice* device = device_at(address, now);
    const I2cStatus s = device == nullptr ? I2cStatus::Nack : device->read_regs(first_reg, out, now);
    if (s != I2cStatus::Ok) ++nacks_;
    return s;
}

}  // namespace glint::firmware::sim
