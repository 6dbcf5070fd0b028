// Register-level models of the raw 9-axis pair for the host build: MPU-6050 (sleep after
// power-on, DEVICE_RESET with a silent window, full-scale settings honoured, data at the
// configured sample rate, big-endian int16 with saturation) and QMC5883L (standby after reset,
// continuous mode at its ODR, DRDY set by a new sample and cleared by reading the data, OVL on
// overflow, range setting honoured). Readings come from ImuPhysics.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "firmware_bridge/firmware/raw_imu_registers.hpp"
#include "firmware_bridge/firmware/sim/imu_physics.hpp"
#include "firmware_bridge/firmware/sim/sim_i2c_bus.hpp"

namespace glint::firmware::sim {

// What the MPU-6050 and QMC5883L models share: the physics they sample, how the chip sits on the
// board, a flat register file, and which output sample is latched in it (so one is taken per
// sample period, however often the driver reads).
template <std::size_t kRegisterCount>
class RegisterFileModel : public I2cDevice {
protected:
    RegisterFileModel(ImuPhysics& physics, AxisRemap mounting) : physics_(physics), mounting_(mounting) {}

    // Power-on state before the chip's own defaults: every register 0, no sample latched.
    void clear_registers() {
        regs_ = {};
        last_tick_ = UINT64_MAX;
    }
    // True once per sample period: `tick` (the period's number) was not latched yet, and now is.
    bool latch_tick(std::uint64_t tick) {
        if (tick == last_tick_) return false;
        last_tick_ = tick;
        return true;
    }
    // A new measurement run starts (e.g. continuous mode entered): the next read latches again.
    void forget_tick() { last_tick_ = UINT64_MAX; }
    void read_registers(std::uint8_t first_reg, std::span<std::uint8_t> out) const {
        read_register_file(regs_, first_reg, out);
    }

    ImuPhysics& physics_;
    AxisRemap mounting_;
    std::array<std::uint8_t, kRegisterCount> regs_{};

private:
    std::uint64_t last_tick_ = UINT64_MAX;
};

class Mpu6050Model final : public RegisterFileModel<mpu6050::kRegisterCount> {
public:
    Mpu6050Model(ImuPhysics& physics, AxisRemap mounting = {});
    I2cStatus write_reg(std::uint8_t reg, std::uint8_t value, std::uint64_t now_us) override;
    I2cStatus read_regs(std::uint8_t first_reg, std::span<std::uint8_t> out, std::uint64_t now_us) override;
    std::uint8_t reg(std::uint8_t r) const { return regs_[r]; }

private:
    void power_on_defaults();
    void refresh(std::uint64_t now_us);

    std::uint64_t silent_until_us_ = 0;
};

class Qmc5883lModel final : public RegisterFileModel<qmc5883l::kRegisterCount> {
public:
    Qmc5883lModel(ImuPhysics& physics, AxisRemap mounting = {});
    I2cStatus write_reg(std::uint8_t reg, std::uint8_t value, std::uint64_t now_us) override;
    I2cStatus read_regs(std::uint8_t first_reg, std::span<std::uint8_t> out, std::uint64_t now_us) override;

private:
    void power_on_defaults();
    void refresh(std::uint64_t now_us);

    std::uint64_t continuous_since_us_ = 0;
};

}  // namespace glint::firmware::sim
