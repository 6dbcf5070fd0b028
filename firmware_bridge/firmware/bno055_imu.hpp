// Driver of the Bosch BNO055 in a fusion mode (NDOF by default, IMU on request), as an
// ImuSource: probe, configuration with the datasheet's mode-switch delays, quaternion and raw
// data reads, calibration status, and recovery from NACKs and chip resets by probing again.
// Non-blocking: every wait is a deadline checked on the next poll().
//
// Frames: the chip's fused quaternion rotates chip axes to East-North-Up (identity when chip x
// points east, y north, z up; Bosch: "heading 0 when +y points north"). The driver turns it into
// sensor -> Glint world (+X east, +Y up, -Z north) as
//   q_world_from_sensor = q_glint_from_enu (x) q_enu_from_chip (x) q_chip_from_sensor
// where q_chip_from_sensor is the board's mounting (an AxisRemap, identity by default; the chip's
// own AXIS_MAP registers are left at their reset value P1).
#pragma once

#include <cstdint>

#include "firmware_bridge/firmware/hal.hpp"
#include "firmware_bridge/firmware/imu_source.hpp"

namespace glint::firmware {

struct Bno055Config {
    std::uint8_t address = 0x28;
    AxisRemap mounting;                         // sensor axis i = sign * chip axis source[i]
    std::uint32_t probe_retry_us = 100'000;     // wait between failed probes
    std::uint32_t status_period_us = 100'000;   // CALIB_STAT / OPR_MODE read period
};

class Bno055Imu final : public ImuSource {
public:
    Bno055Imu(I2cBus& bus, Bno055Config config = {});

    std::uint32_t capabilities() const override;
    bool set_mode(protocol::FusionMode mode) override;
    protocol::FusionMode mode() const override { return mode_; }
    bool has_gains() const override { return false; }
    bool set_gains(float, float) override { return false; }  // the chip's fusion has no knobs
    void gains(float& kp, float& ki) const override { kp = ki = 0.0f; }
    ImuStatus poll(std::uint64_t now_us, ImuReading& reading) override;
    std::uint32_t last_fault_sensors() const override;

    enum class State : std::uint8_t { Probe, EnteringConfig, EnteringFusion, Running };
    State state() const { return state_; }
    std::uint32_t probes() const { return probes_; }  // probe attempts since construction

    // Conversions of the chip's raw registers (public for tests).
    static Quatf quaternion_from_registers(const std::uint8_t* bytes8);  // chip -> ENU, unit
    static CalibrationLevels calibration_from_register(std::uint8_t calib_stat);

private:
    ImuStatus fail(std::uint64_t now_us);
    ImuStatus probe(std::uint64_t now_us);
    ImuStatus read_sample(std::uint64_t now_us, ImuReading& reading);
    std::uint8_t chip_mode() const;

    I2cBus& bus_;
    Bno055Config config_;
    Quatf world_from_chip_enu_;   // q_glint_from_enu, fixed
    Quatf chip_from_sensor_;      // mounting
    protocol::FusionMode mode_ = protocol::FusionMode::Ndof;
    State state_ = State::Probe;
    std::uint64_t deadline_us_ = 0;     // earliest time of the next state step
    std::uint64_t next_status_us_ = 0;
    CalibrationLevels calibration_{};
    std::uint32_t probes_ = 0;
    bool in_boot_grace(std::uint64_t now_us) const;
    bool polled_ = false;
    bool answered_once_ = false;
    std::uint64_t first_poll_us_ = 0;
};

}  // namespace glint::firmware
