// Register-level model of a BNO055 for the host build: page 0/1 registers, boot time, the
// mode-switch windows (transfers are NACKed while the chip switches, so a driver that does not
// wait the datasheet's times fails), fusion output at 100 Hz, raw data, CALIB_STAT, SYS_TRIGGER
// reset. The "fusion" is the true orientation from ImuPhysics, quantised to the registers'
// 2^-14 resolution and the chip's 100 Hz output rate: the model tests the driver, not Bosch's
// filter.
#pragma once

#include <array>
#include <cstdint>

#include "firmware_bridge/firmware/sim/imu_physics.hpp"
#include "firmware_bridge/firmware/sim/sim_i2c_bus.hpp"

namespace glint::firmware::sim {

struct Bno055ModelConfig {
    AxisRemap mounting;               // chip axes on the board (same meaning as the driver's)
    std::uint64_t power_on_us = 0;    // board time of power-on; I2C silent for the boot time
    std::uint8_t initial_page = 0;    // page left selected at power-on (a driver must select 0)
    // Calibration schedule of the model, seconds in a fusion mode until each level reaches 3.
    double gyro_calibrated_s = 1.0;
    double accel_calibrated_s = 3.0;
    double mag_calibrated_s = 5.0;
};

class Bno055Model final : public I2cDevice {
public:
    Bno055Model(ImuPhysics& physics, Bno055ModelConfig config = {});

    I2cStatus write_reg(std::uint8_t reg, std::uint8_t value, std::uint64_t now_us) override;
    I2cStatus read_regs(std::uint8_t first_reg, std::span<std::uint8_t> out, std::uint64_t now_us) override;

    // Simulates a brown-out at `now_us`: reboot (silent for the boot time), back in CONFIGMODE.
    void reset(std::uint64_t now_us);

    std::uint8_t operating_mode() const { return mode_; }
    std::uint32_t mode_switches() const { return mode_switches_; }
    std::uint32_t transfers_during_switch() const { return transfers_during_switch_; }

private:
    bool busy(std::uint64_t now_us);
    void refresh_outputs(std::uint64_t now_us);

    ImuPhysics& physics_;
    Bno055ModelConfig config_;
    std::array<std::array<std::uint8_t, 0x80>, 2> pages_{};
    std::uint8_t page_ = 0;
    std::uint8_t mode_ = 0;                // current operating mode (low 4 bits of OPR_MODE)
    std::uint64_t silent_until_us_ = 0;    // boot or mode switch in progress until then
    std::uint64_t fusion_since_us_ = 0;
    std::uint64_t last_output_tick_ = UINT64_MAX;
    std::uint32_t mode_switches_ = 0;
    std::uint32_t transfers_during_switch_ = 0;
};

}  // namespace glint::firmware::sim
