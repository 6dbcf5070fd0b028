// Register-level models of the raw 9-axis pair for the host build: MPU-6050 (sleep after
// power-on, DEVICE_RESET with a silent window, full-scale settings honoured, data at the
// configured sample rate, big-endian int16 with saturation) and QMC5883L (standby after reset,
// continuous mode at its ODR, DRDY set by a new sample and cleared by reading the data, OVL on
// overflow, range setting honoured). Readings come from ImuPhysics.
#pragma once

#include <array>
#include <cstdint>

#include "firmware_bridge/firmware/raw_imu_registers.hpp"
#include "firmware_bridge/firmware/sim/imu_physics.hpp"
#include "firmware_bridge/firmware/sim/sim_i2c_bus.hpp"

namespace glint::firmware::sim {

class Mpu6050Model final : public I2cDevice {
public:
    Mpu6050Model(ImuPhysics& physics, AxisRemap mounting = {});
    I2cStatus write_reg(std::uint8_t reg, std::uint8_t value, std::uint64_t now_us) override;
    I2cStatus read_regs(std::uint8_t first_reg, std::span<std::uint8_t> out, std::uint64_t now_us) override;
    std::uint8_t reg(std::uint8_t r) const { return regs_[r]; }

private:
    void power_on_defaults();
    void refresh(std::uint64_t now_us);

    ImuPhysics& physics_;
    AxisRemap mounting_;
    std::array<std::uint8_t, mpu6050::kRegisterCount> regs_{};
    std::uint64_t silent_until_us_ = 0;
    std::uint64_t last_tick_ = UINT64_MAX;
};

class Qmc5883lModel final : public I2cDevice {
public:
    Qmc5883lModel(ImuPhysics& physics, AxisRemap mounting = {});
    I2cStatus write_reg(std::uint8_t reg, std::uint8_t value, std::uint64_t now_us) override;
    I2cStatus read_regs(std::uint8_t first_reg, std::span<std::uint8_t> out, std::uint64_t now_us) override;

private:
    void power_on_defaults();
    void refresh(std::uint64_t now_us);

    ImuPhysics& physics_;
    AxisRemap mounting_;
    std::array<std::uint8_t, qmc5883l::kRegisterCount> regs_{};
    std::uint64_t continuous_since_us_ = 0;
    std::uint64_t last_tick_ = UINT64_MAX;
};

}  // namespace glint::firmware::sim
