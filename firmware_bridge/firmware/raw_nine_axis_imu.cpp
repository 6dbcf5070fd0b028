// MPU-6050 + QMC5883L drivers and board-side fusion: see raw_nine_axis_imu.hpp.
#include "firmware_bridge/firmware/raw_nine_axis_imu.hpp"

#include <array>

#include "firmware_bridge/firmware/raw_imu_registers.hpp"
#include "firmware_bridge/firmware/register_bytes.hpp"

namespace glint::firmware {

namespace capability = protocol::capability;
namespace raw_valid = protocol::raw_valid;

namespace {
constexpr float kStandardGravity = 9.80665f;  // m/s^2 per g
constexpr float kRadPerDeg = 0.017453292519943295f;
}  // namespace

RawNineAxisImu::RawNineAxisImu(I2cBus& bus, RawNineAxisConfig config)
    : bus_(bus), config_(config), filter_(config.gains) {}

std::uint32_t RawNineAxisImu::capabilities() const {
    return capability::kGyro | capability::kAccel | capability::kMag | capability::kOnBoardFusion |
           capability::kRawImu;
}

bool RawNineAxisImu::set_mode(protocol::FusionMode mode) {
    if (mode != protocol::FusionMode::Off && mode != protocol::FusionMode::Imu &&
        mode != protocol::FusionMode::Ndof) {
        return false;
    }
    if (mode != mode_) {
        mode_ = mode;
        // Imu mode defines heading by the start attitude, Ndof by north: start the estimate again,
        // from a new field sample (the last one may be minutes old).
        filter_.reset();
        have_mag_ = false;
        mag_trusted_ = false;
    }
    return true;
}

bool RawNineAxisImu::set_gains(float kp, float ki) {
    // Negative gains make the filter unstable; very large ones make it follow the accelerometer
    // noise only. 0 is allowed (pure gyro integration / no bias estimation).
    if (!(kp >= 0.0f && kp <= 50.0f && ki >= 0.0f && ki <= 10.0f)) return false;
    MahonyGains g = filter_.gains();
    g.kp = kp;
    g.ki = ki;
    filter_.set_gains(g);
    return true;
}

void RawNineAxisImu::gains(float& kp, float& ki) const {
    kp = filter_.gains().kp;
    ki = filter_.gains().ki;
}

ImuStatus RawNineAxisImu::fail_main(std::uint64_t now_us) {
    state_ = State::Probe;
    deadline_us_ = now_us;
    fault_sensors_ = capability::kGyro | capability::kAccel;
    have_last_sample_ = false;
    return ImuStatus::ReadFailed;
}

bool RawNineAxisImu::configure_gyro_accel() {
    const std::uint8_t a = mpu6050::kAddress;
    if (bus_.write_reg(a, mpu6050::kRegPwrMgmt1, mpu6050::kPwrClockPllGyroX) != I2cStatus::Ok ||
        bus_.write_reg(a, mpu6050::kRegConfig, mpu6050::kConfigDlpf44Hz) != I2cStatus::Ok ||
        bus_.write_reg(a, mpu6050::kRegSmplrtDiv, mpu6050::kSmplrtDiv200Hz) != I2cStatus::Ok ||
        bus_.write_reg(a, mpu6050::kRegGyroConfig, mpu6050::kGyroFs500Dps) != I2cStatus::Ok ||
        bus_.write_reg(a, mpu6050::kRegAccelConfig, mpu6050::kAccelFs4G) != I2cStatus::Ok) {
        return false;
    }
    // Read the scale registers back: a wrong full-scale setting would scale every sample.
    std::array<std::uint8_t, 2> scales{};
    return bus_.read_regs(a, mpu6050::kRegGyroConfig, scales) == I2cStatus::Ok &&
           scales[0] == mpu6050::kGyroFs500Dps && scales[1] == mpu6050::kAccelFs4G;
}

bool RawNineAxisImu::start_mag() {
    const std::uint8_t a = qmc5883l::kAddress;
    std::uint8_t id = 0;
    return bus_.read_regs(a, qmc5883l::kRegChipId, {&id, 1}) == I2cStatus::Ok &&
           id == qmc5883l::kChipId &&
           bus_.write_reg(a, qmc5883l::kRegControl2, qmc5883l::kSoftReset) == I2cStatus::Ok &&
           bus_.write_reg(a, qmc5883l::kRegSetReset, 0x01) == I2cStatus::Ok &&
           bus_.write_reg(a, qmc5883l::kRegControl1, qmc5883l::kControl1Continuous100Hz8G) ==
               I2cStatus::Ok;
}

CalibrationLevels RawNineAxisImu::calibration(std::uint64_t now_us, bool accel_ok, bool mag_ok) {
    // Gyro: the bias estimate has settled when it moves little within a second.
    if (now_us >= bias_check_us_ + 1'000'000) {
        const float moved_deg_s = norm(filter_.gyro_bias_rad_s() - bias_at_check_) / kRadPerDeg;
        gyro_level_ = moved_deg_s < 0.02f ? 3 : (moved_deg_s < 0.1f ? 2 : (moved_deg_s < 0.5f ? 1 : 0));
        bias_at_check_ = filter_.gyro_bias_rad_s();
        bias_check_us_ = now_us;
    }
    CalibrationLevels c;
    c.gyro = gyro_level_;
    // Factory-trimmed accelerometer: 3 while it reads gravity, 2 while the board is accelerated.
    c.accel = accel_ok ? 3 : 2;
    // Magnetometer: 3 while the field matches the reference, 1 while disturbed, 0 when absent.
    c.mag = mode_ != protocol::FusionMode::Ndof || !mag_running_ ? 0 : (mag_ok ? 3 : 1);
    c.system = c.gyro < c.accel ? c.gyro : c.accel;
    if (mode_ == protocol::FusionMode::Ndof && c.mag < c.system) c.system = c.mag;
    if (mode_ == protocol::FusionMode::Off) c.system = 0;
    return c;
}

ImuStatus RawNineAxisImu::poll(std::uint64_t now_us, ImuReading& reading) {
    const std::uint8_t a = mpu6050::kAddress;
    if (state_ == State::Probe) {
        if (now_us < deadline_us_) return ImuStatus::NotResponding;
        std::uint8_t who = 0;
        if (bus_.read_regs(a, mpu6050::kRegWhoAmI, {&who, 1}) != I2cStatus::Ok ||
            who != mpu6050::kWhoAmI ||
            bus_.write_reg(a, mpu6050::kRegPwrMgmt1, mpu6050::kPwrReset) != I2cStatus::Ok) {
            deadline_us_ = now_us + config_.probe_retry_us;
            fault_sensors_ = capability::kGyro | capability::kAccel;
            return ImuStatus::NotResponding;
        }
        state_ = State::ResetWait;
        deadline_us_ = now_us + mpu6050::kResetTimeUs;
        return ImuStatus::Starting;
    }
    if (state_ == State::ResetWait) {
        if (now_us < deadline_us_) return ImuStatus::Starting;
        if (!configure_gyro_accel()) return fail_main(now_us);
        state_ = State::Running;
        mag_running_ = false;
        mag_retry_at_us_ = now_us;
        have_mag_ = false;
        fault_sensors_ = 0;
    }

    std::array<std::uint8_t, mpu6050::kBurstSize> burst{};
    if (bus_.read_regs(a, mpu6050::kRegAccelXoutH, burst) != I2cStatus::Ok) return fail_main(now_us);
    const Vec3f accel_chip{int16_be(&burst[0]) * (kStandardGravity / mpu6050::kAccelLsbPerG),
                           int16_be(&burst[2]) * (kStandardGravity / mpu6050::kAccelLsbPerG),
                           int16_be(&burst[4]) * (kStandardGravity / mpu6050::kAccelLsbPerG)};
    const float rad_s_per_lsb = kRadPerDeg / mpu6050::kGyroLsbPerDps;
    const Vec3f gyro_chip{int16_be(&burst[8]) * rad_s_per_lsb, int16_be(&burst[10]) * rad_s_per_lsb,
                          int16_be(&burst[12]) * rad_s_per_lsb};
    const Vec3f accel = config_.gyro_accel_mounting.to_sensor(accel_chip);
    const Vec3f gyro = config_.gyro_accel_mounting.to_sensor(gyro_chip);

    // Magnetometer: only in Ndof; a missing one is re-probed once a second.
    bool mag_fault = false;
    bool mag_fresh = false;  // a new field sample this poll
    if (mode_ == protocol::FusionMode::Ndof) {
        if (!mag_running_ && now_us >= mag_retry_at_us_) {
            mag_running_ = start_mag();
            if (!mag_running_) {
                mag_retry_at_us_ = now_us + config_.mag_retry_us;
                mag_fault = true;
            }
        }
        if (mag_running_) {
            std::array<std::uint8_t, qmc5883l::kBurstSize> m{};
            if (bus_.read_regs(qmc5883l::kAddress, qmc5883l::kRegDataX, m) != I2cStatus::Ok) {
                mag_running_ = false;
                have_mag_ = false;
                mag_retry_at_us_ = now_us + config_.mag_retry_us;
                mag_fault = true;
            } else if ((m[6] & qmc5883l::kStatusOverflow) != 0) {
                have_mag_ = false;  // field beyond +-8 gauss: a magnet on the board, not the earth
            } else if ((m[6] & qmc5883l::kStatusDrdy) == 0 && have_mag_ &&
                       now_us - last_fresh_mag_us_ > config_.mag_silent_us) {
                // Reads succeed but no sample comes: restarted like a chip that failed.
                mag_running_ = false;
                have_mag_ = false;
                mag_retry_at_us_ = now_us;
                mag_fault = true;
            } else if ((m[6] & qmc5883l::kStatusDrdy) != 0) {
                // 100 Hz output data rate: a new sample every other poll at 200 Hz, fused once.
                const Vec3f chip{int16_le(&m[0]) / qmc5883l::kLsbPerUt,
                                 int16_le(&m[2]) / qmc5883l::kLsbPerUt,
                                 int16_le(&m[4]) / qmc5883l::kLsbPerUt};
                last_mag_ut_ = config_.mag_mounting.to_sensor(chip);
                have_mag_ = true;
                mag_fresh = true;
                last_fresh_mag_us_ = now_us;
            }
        }
    }
    fault_sensors_ = mag_fault ? capability::kMag : 0;

    const bool use_mag = mode_ == protocol::FusionMode::Ndof && mag_running_ && have_mag_;
    const float dt_s =
        have_last_sample_ ? static_cast<float>(now_us - last_sample_us_) * 1e-6f : 0.0f;
    // In Ndof the first estimate waits for the first field sample (10 ms at 100 Hz), so the
    // heading starts from north rather than from the sensor's -Z; without a running
    // magnetometer it starts at once.
    const bool wait_for_mag = mode_ == protocol::FusionMode::Ndof && mag_running_ && !have_mag_ &&
                              !filter_.initialised();
    if (mode_ != protocol::FusionMode::Off && !wait_for_mag) {
        // The field only when the chip has a new sample: fused again, the previous one (5 ms old
        // at every other poll) held the heading 2.5 ms behind the tilt in a steady turn (the
        // filter weights each sample by the time since the last, mahony_filter.hpp).
        const bool pass_mag = use_mag && (mag_fresh || !filter_.initialised());
        filter_.update(gyro, accel, pass_mag ? &last_mag_ut_ : nullptr, dt_s);
        // The field's verdict stands until the next sample is judged (the status would flip
        // at every poll between samples otherwise, and each change is sent at once).
        if (pass_mag && filter_.integrated()) mag_trusted_ = filter_.mag_used();
    }
    if (!use_mag) mag_trusted_ = false;
    have_last_sample_ = true;
    last_sample_us_ = now_us;

    reading = ImuReading{};
    reading.timestamp_us = now_us;
    reading.gyro_bias_rad_s = filter_.gyro_bias_rad_s();
    reading.gyro_rad_s = gyro - reading.gyro_bias_rad_s;  // bias-corrected, as RawImu asks
    reading.accel_m_s2 = accel;
    reading.raw_valid = raw_valid::kGyro | raw_valid::kAccel;
    if (use_mag) {
        reading.mag_ut = last_mag_ut_;
        reading.raw_valid |= raw_valid::kMag;
    }
    if (mode_ != protocol::FusionMode::Off && filter_.initialised()) {
        reading.has_orientation = true;
        reading.world_from_sensor = filter_.orientation();
    }
    reading.calibration = calibration(now_us, filter_.accel_used(), mag_trusted_);
    return mag_fault ? ImuStatus::Degraded : ImuStatus::Ok;
}

}  // namespace glint::firmware
