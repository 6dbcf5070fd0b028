// BNO055 driver: see bno055_imu.hpp.
#include "firmware_bridge/firmware/bno055_imu.hpp"

#include <array>

#include "firmware_bridge/firmware/bno055_registers.hpp"
#include "firmware_bridge/firmware/register_bytes.hpp"

namespace glint::firmware {

namespace capability = protocol::capability;

Bno055Imu::Bno055Imu(I2cBus& bus, Bno055Config config)
    : bus_(bus),
      config_(config),
      world_from_chip_enu_(glint_world_from_enu()),
      chip_from_sensor_(config.mounting.sensor_to_chip()) {}

std::uint32_t Bno055Imu::capabilities() const {
    return capability::kGyro | capability::kAccel | capability::kMag | capability::kOnBoardFusion |
           capability::kRawImu;
}

std::uint32_t Bno055Imu::last_fault_sensors() const {
    // One chip holds all three sensors: a fault concerns all of them.
    return capability::kGyro | capability::kAccel | capability::kMag;
}

bool Bno055Imu::set_mode(protocol::FusionMode mode) {
    // Off would need the chip's AMG mode and raw-only output; not offered by this driver.
    if (mode != protocol::FusionMode::Ndof && mode != protocol::FusionMode::Imu) return false;
    if (mode != mode_) {
        mode_ = mode;
        state_ = State::Probe;  // the chip must pass through CONFIGMODE to change mode
        deadline_us_ = 0;
    }
    return true;
}

std::uint8_t Bno055Imu::chip_mode() const {
    return mode_ == protocol::FusionMode::Imu ? bno055::kModeImu : bno055::kModeNdof;
}

Quatf Bno055Imu::quaternion_from_registers(const std::uint8_t* b) {
    const Quatf raw{int16_le(b) / bno055::kQuaLsb, int16_le(b + 2) / bno055::kQuaLsb,
                    int16_le(b + 4) / bno055::kQuaLsb, int16_le(b + 6) / bno055::kQuaLsb};
    return normalized(raw);
}

CalibrationLevels Bno055Imu::calibration_from_register(std::uint8_t v) {
    return {static_cast<std::uint8_t>((v >> 6) & 3), static_cast<std::uint8_t>((v >> 4) & 3),
            static_cast<std::uint8_t>((v >> 2) & 3), static_cast<std::uint8_t>(v & 3)};
}

// Any failed transfer: the chip may have reset, be rebooting or be gone. Start over with a
// probe on the next poll (not retried at once, so a dead bus does not busy-loop).
ImuStatus Bno055Imu::fail(std::uint64_t now_us) {
    state_ = State::Probe;
    deadline_us_ = now_us;
    return ImuStatus::ReadFailed;
}

// Until the chip has answered once, silence for its boot time after the first poll (power-on)
// is expected.
bool Bno055Imu::in_boot_grace(std::uint64_t now_us) const {
    return !answered_once_ && now_us < first_poll_us_ + bno055::kBootTimeUs + config_.probe_retry_us;
}

ImuStatus Bno055Imu::probe(std::uint64_t now_us) {
    ++probes_;
    std::uint8_t id = 0;
    // Page 0 first: CHIP_ID is a page-0 register and PAGE_ID is readable/writable on both pages.
    if (bus_.write_reg(config_.address, bno055::kRegPageId, 0) != I2cStatus::Ok ||
        bus_.read_regs(config_.address, bno055::kRegChipId, {&id, 1}) != I2cStatus::Ok ||
        id != bno055::kChipId) {
        deadline_us_ = now_us + config_.probe_retry_us;
        // Silence during the chip's boot after power-on is expected, not a fault.
        return in_boot_grace(now_us) ? ImuStatus::Starting : ImuStatus::NotResponding;
    }
    answered_once_ = true;
    // Whatever mode the chip is in, go to CONFIGMODE and wait the longer switching time.
    if (bus_.write_reg(config_.address, bno055::kRegOprMode, bno055::kModeConfig) != I2cStatus::Ok) {
        return fail(now_us);
    }
    state_ = State::EnteringConfig;
    deadline_us_ = now_us + bno055::kOperatingToConfigUs;
    return ImuStatus::Starting;
}

ImuStatus Bno055Imu::poll(std::uint64_t now_us, ImuReading& reading) {
    const std::uint8_t a = config_.address;
    if (!polled_) {
        polled_ = true;
        first_poll_us_ = now_us;
    }
    switch (state_) {
        case State::Probe:
            if (now_us < deadline_us_) {
                return in_boot_grace(now_us) ? ImuStatus::Starting : ImuStatus::NotResponding;
            }
            return probe(now_us);
        case State::EnteringConfig:
            if (now_us < deadline_us_) return ImuStatus::Starting;
            // Normal power, SI units (m/s^2, deg/s), default axis map P1, then the fusion mode.
            if (bus_.write_reg(a, bno055::kRegPwrMode, 0x00) != I2cStatus::Ok ||
                bus_.write_reg(a, bno055::kRegUnitSel, 0x00) != I2cStatus::Ok ||
                bus_.write_reg(a, bno055::kRegOprMode, chip_mode()) != I2cStatus::Ok) {
                return fail(now_us);
            }
            state_ = State::EnteringFusion;
            deadline_us_ = now_us + bno055::kConfigToOperatingUs;
            return ImuStatus::Starting;
        case State::EnteringFusion: {
            if (now_us < deadline_us_) return ImuStatus::Starting;
            std::uint8_t mode = 0;
            if (bus_.read_regs(a, bno055::kRegOprMode, {&mode, 1}) != I2cStatus::Ok ||
                (mode & 0x0F) != chip_mode()) {
                return fail(now_us);
            }
            state_ = State::Running;
            next_status_us_ = now_us;
            return read_sample(now_us, reading);
        }
        case State::Running:
            return read_sample(now_us, reading);
    }
    return ImuStatus::ReadFailed;
}

ImuStatus Bno055Imu::read_sample(std::uint64_t now_us, ImuReading& reading) {
    const std::uint8_t a = config_.address;
    if (now_us >= next_status_us_) {
        std::array<std::uint8_t, bno055::kStatusSize> status{};
        if (bus_.read_regs(a, bno055::kStatusFirst, status) != I2cStatus::Ok) return fail(now_us);
        // A chip that reset on its own (brown-out) answers again, but in CONFIGMODE with its
        // output registers frozen: configure it again.
        if ((status[bno055::kRegOprMode - bno055::kStatusFirst] & 0x0F) != chip_mode()) {
            return fail(now_us);
        }
        calibration_ = calibration_from_register(status[0]);
        next_status_us_ = now_us + config_.status_period_us;
    }

    std::array<std::uint8_t, bno055::kBurstSize> burst{};
    if (bus_.read_regs(a, bno055::kBurstFirst, burst) != I2cStatus::Ok) return fail(now_us);
    const auto vec_at = [&](std::uint8_t reg, float lsb_per_unit) {
        const std::uint8_t* p = burst.data() + (reg - bno055::kBurstFirst);
        const Vec3f chip{int16_le(p) / lsb_per_unit, int16_le(p + 2) / lsb_per_unit,
                         int16_le(p + 4) / lsb_per_unit};
        return config_.mounting.to_sensor(chip);
    };
    constexpr float kRadPerDeg = 0.017453292519943295f;

    reading = ImuReading{};
    reading.timestamp_us = now_us;
    reading.accel_m_s2 = vec_at(bno055::kRegAccData, bno055::kAccLsbPerMs2);
    reading.gyro_rad_s = kRadPerDeg * vec_at(bno055::kRegGyrData, bno055::kGyrLsbPerDps);
    reading.raw_valid = protocol::raw_valid::kGyro | protocol::raw_valid::kAccel;
    if (mode_ == protocol::FusionMode::Ndof) {
        reading.mag_ut = vec_at(bno055::kRegMagData, bno055::kMagLsbPerUt);
        reading.raw_valid |= protocol::raw_valid::kMag;
    }
    reading.calibration = calibration_;

    const std::uint8_t* q = burst.data() + (bno055::kRegQuaData - bno055::kBurstFirst);
    // All zeros until the fusion has produced its first estimate after a mode switch.
    const bool fused = (q[0] | q[1] | q[2] | q[3] | q[4] | q[5] | q[6] | q[7]) != 0;
    if (fused) {
        const Quatf enu_from_chip = quaternion_from_registers(q);
        reading.world_from_sensor =
            normalized(world_from_chip_enu_ * enu_from_chip * chip_from_sensor_);
        reading.has_orientation = true;
    }
    return ImuStatus::Ok;
}

}  // namespace glint::firmware
