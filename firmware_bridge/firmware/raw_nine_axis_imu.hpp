// Raw 9-axis IMU fused on the board: an MPU-6050 (gyro + accel, I2C 0x68) and a QMC5883L
// (magnetometer, I2C 0x0D) read over I2C, remapped to the sensor frame and fused by a
// MahonyFilter (Ndof with the magnetometer, Imu without, Off = raw samples only).
//
// Registers used (raw_imu_registers.hpp):
//   MPU-6050: WHO_AM_I 0x75 (= 0x68), PWR_MGMT_1 0x6B (0x80 reset, then 0x01 PLL/awake),
//             CONFIG 0x1A (0x03 DLPF 44 Hz), SMPLRT_DIV 0x19 (0x04: 200 Hz), GYRO_CONFIG 0x1B
//             (0x08: +-500 deg/s, 65.5 LSB per deg/s), ACCEL_CONFIG 0x1C (0x08: +-4 g, 8192 LSB/g),
//             data burst 0x3B..0x48 (accel xyz, temperature, gyro xyz; int16 big-endian).
//   QMC5883L: chip id 0x0D (= 0xFF), CONTROL2 0x0A (0x80 soft reset), SET/RESET 0x0B (0x01),
//             CONTROL1 0x09 (0x19: continuous, 100 Hz, 8 gauss, OSR 512; 30 LSB per uT),
//             data burst 0x00..0x06 (x, y, z int16 little-endian, STATUS: DRDY bit 0, OVL bit 1).
// A failing MPU-6050 stops the samples (re-probed at once); a failing magnetometer only drops
// the heading correction while it is re-probed once a second.
#pragma once

#include <cstdint>

#include "firmware_bridge/firmware/hal.hpp"
#include "firmware_bridge/firmware/imu_source.hpp"
#include "firmware_bridge/firmware/mahony_filter.hpp"

namespace glint::firmware {

struct RawNineAxisConfig {
    AxisRemap gyro_accel_mounting;  // MPU-6050 chip axes -> sensor axes
    AxisRemap mag_mounting;         // QMC5883L chip axes -> sensor axes
    MahonyGains gains;
    std::uint32_t probe_retry_us = 100'000;
    std::uint32_t mag_retry_us = 1'000'000;
    // No new field sample for this long (10 of the chip's 100 Hz periods) while its reads succeed:
    // the chip stopped converting (a brown-out leaves it in standby); it is restarted.
    std::uint32_t mag_silent_us = 100'000;
};

class RawNineAxisImu final : public ImuSource {
public:
    RawNineAxisImu(I2cBus& bus, RawNineAxisConfig config = {});

    std::uint32_t capabilities() const override;
    bool set_mode(protocol::FusionMode mode) override;
    protocol::FusionMode mode() const override { return mode_; }
    bool has_gains() const override { return true; }
    bool set_gains(float kp, float ki) override;
    void gains(float& kp, float& ki) const override;
    ImuStatus poll(std::uint64_t now_us, ImuReading& reading) override;
    std::uint32_t last_fault_sensors() const override { return fault_sensors_; }

    const MahonyFilter& filter() const { return filter_; }
    bool mag_running() const { return mag_running_; }

private:
    enum class State : std::uint8_t { Probe, ResetWait, Running };
    ImuStatus fail_main(std::uint64_t now_us);
    bool configure_gyro_accel();
    bool start_mag();
    CalibrationLevels calibration(std::uint64_t now_us, bool accel_ok, bool mag_ok);

    I2cBus& bus_;
    RawNineAxisConfig config_;
    MahonyFilter filter_;
    protocol::FusionMode mode_ = protocol::FusionMode::Ndof;
    State state_ = State::Probe;
    std::uint64_t deadline_us_ = 0;
    bool mag_running_ = false;
    std::uint64_t mag_retry_at_us_ = 0;
    bool have_mag_ = false;
    bool mag_trusted_ = false;  // the last field sample fused was plausible (mahony_filter.hpp)
    std::uint64_t last_fresh_mag_us_ = 0;  // when the chip last had a new sample
    Vec3f last_mag_ut_;
    bool have_last_sample_ = false;
    std::uint64_t last_sample_us_ = 0;
    std::uint32_t fault_sensors_ = 0;
    // Gyro calibration level from how much the bias estimate moved over the last second.
    std::uint64_t bias_check_us_ = 0;
    Vec3f bias_at_check_;
    std::uint8_t gyro_level_ = 0;
};

}  // namespace glint::firmware
