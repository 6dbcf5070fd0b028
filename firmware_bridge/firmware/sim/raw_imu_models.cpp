// MPU-6050 and QMC5883L register models: see raw_imu_models.hpp.
#include "firmware_bridge/firmware/sim/raw_imu_models.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "firmware_bridge/firmware/register_bytes.hpp"

namespace glint::firmware::sim {
namespace {

bool fits_i16(double v) { return v >= -32768.0 && v <= 32767.0; }
std::int16_t saturate_i16(double v) {
    return static_cast<std::int16_t>(std::clamp(std::round(v), -32768.0, 32767.0));
}

}  // namespace

// ---- MPU-6050 ----

Mpu6050Model::Mpu6050Model(ImuPhysics& physics, AxisRemap mounting)
    : RegisterFileModel(physics, mounting) {
    power_on_defaults();
}

void Mpu6050Model::power_on_defaults() {
    clear_registers();
    regs_[mpu6050::kRegWhoAmI] = mpu6050::kWhoAmI;
    regs_[mpu6050::kRegPwrMgmt1] = 0x40;  // SLEEP after power-on (register map 4.28)
}

I2cStatus Mpu6050Model::write_reg(std::uint8_t reg, std::uint8_t value, std::uint64_t now_us) {
    if (now_us < silent_until_us_) return I2cStatus::Nack;
    if (reg >= mpu6050::kRegisterCount || reg == mpu6050::kRegWhoAmI) return I2cStatus::Ok;
    if (reg == mpu6050::kRegPwrMgmt1 && (value & mpu6050::kPwrReset) != 0) {
        power_on_defaults();
        silent_until_us_ = now_us + mpu6050::kResetTimeUs;
        return I2cStatus::Ok;
    }
    regs_[reg] = value;
    return I2cStatus::Ok;
}

void Mpu6050Model::refresh(std::uint64_t now_us) {
    if ((regs_[mpu6050::kRegPwrMgmt1] & 0x40) != 0) return;  // asleep: data registers frozen
    // Sample rate = gyro output rate / (1 + SMPLRT_DIV); 1 kHz with the DLPF on, 8 kHz off.
    const bool dlpf = (regs_[mpu6050::kRegConfig] & 0x07) != 0 && (regs_[mpu6050::kRegConfig] & 0x07) != 7;
    const std::uint64_t period_us = (dlpf ? 1000u : 125u) * (1u + regs_[mpu6050::kRegSmplrtDiv]);
    const std::uint64_t tick = now_us / period_us;
    if (!latch_tick(tick)) return;
    const SensorReadings r = physics_.read(tick * period_us);
    const double gyro_lsb_per_dps = 131.0 / static_cast<double>(1u << ((regs_[mpu6050::kRegGyroConfig] >> 3) & 3));
    const double accel_lsb_per_g = 16384.0 / static_cast<double>(1u << ((regs_[mpu6050::kRegAccelConfig] >> 3) & 3));
    const Vec3d accel = mounting_.to_chip(r.accel_m_s2) * (accel_lsb_per_g / kGravity);
    const Vec3d gyro = mounting_.to_chip(r.gyro_rad_s) * (gyro_lsb_per_dps * 180.0 / std::numbers::pi);
    std::uint8_t* p = &regs_[mpu6050::kRegAccelXoutH];
    put_int16_be(p + 0, saturate_i16(accel.x));
    put_int16_be(p + 2, saturate_i16(accel.y));
    put_int16_be(p + 4, saturate_i16(accel.z));
    put_int16_be(p + 6, saturate_i16((25.0 - 36.53) * 340.0));  // 25 degC (register map 4.18)
    put_int16_be(p + 8, saturate_i16(gyro.x));
    put_int16_be(p + 10, saturate_i16(gyro.y));
    put_int16_be(p + 12, saturate_i16(gyro.z));
}

I2cStatus Mpu6050Model::read_regs(std::uint8_t first_reg, std::span<std::uint8_t> out, std::uint64_t now_us) {
    if (now_us < silent_until_us_) return I2cStatus::Nack;
    refresh(now_us);
    read_registers(first_reg, out);
    return I2cStatus::Ok;
}

// ---- QMC5883L ----

Qmc5883lModel::Qmc5883lModel(ImuPhysics& physics, AxisRemap mounting)
    : RegisterFileModel(physics, mounting) {
    power_on_defaults();
}

void Qmc5883lModel::power_on_defaults() {
    clear_registers();
    regs_[qmc5883l::kRegChipId] = qmc5883l::kChipId;  // standby mode (CONTROL1 = 0)
}

I2cStatus Qmc5883lModel::write_reg(std::uint8_t reg, std::uint8_t value, std::uint64_t now_us) {
    if (reg >= qmc5883l::kRegisterCount || reg == qmc5883l::kRegChipId) return I2cStatus::Ok;
    if (reg == qmc5883l::kRegControl2 && (value & qmc5883l::kSoftReset) != 0) {
        power_on_defaults();
        return I2cStatus::Ok;
    }
    if (reg == qmc5883l::kRegControl1 && (value & 3) == 1 && (regs_[reg] & 3) != 1) {
        continuous_since_us_ = now_us;
        forget_tick();
    }
    regs_[reg] = value;
    return I2cStatus::Ok;
}

void Qmc5883lModel::refresh(std::uint64_t now_us) {
    const std::uint8_t control = regs_[qmc5883l::kRegControl1];
    if ((control & 3) != 1) return;  // not in continuous mode
    static constexpr std::uint64_t kPeriodUs[4] = {100'000, 20'000, 10'000, 5'000};  // 10..200 Hz
    const std::uint64_t period_us = kPeriodUs[(control >> 2) & 3];
    if (now_us < continuous_since_us_ + period_us) return;  // first conversion not done yet
    const std::uint64_t tick = (now_us - continuous_since_us_) / period_us;
    if (!latch_tick(tick)) return;
    const SensorReadings r = physics_.read(continuous_since_us_ + tick * period_us);
    const double lsb_per_ut = ((control >> 4) & 3) == 1 ? 30.0 : 120.0;  // 8 G : 2 G
    const Vec3d v = mounting_.to_chip(r.mag_ut) * lsb_per_ut;
    const bool overflow = !fits_i16(v.x) || !fits_i16(v.y) || !fits_i16(v.z);
    put_int16_le(&regs_[0], saturate_i16(v.x));
    put_int16_le(&regs_[2], saturate_i16(v.y));
    put_int16_le(&regs_[4], saturate_i16(v.z));
    regs_[qmc5883l::kRegStatus] = static_cast<std::uint8_t>(
        qmc5883l::kStatusDrdy | (overflow ? qmc5883l::kStatusOverflow : 0));
}

I2cStatus Qmc5883lModel::read_regs(std::uint8_t first_reg, std::span<std::uint8_t> out, std::uint64_t now_us) {
    refresh(now_us);
    read_registers(first_reg, out);
    // DRDY (and OVL with it) is cleared once the data registers (0x00..0x05) have been read.
    const bool read_data = !out.empty() && first_reg <= 0x05;
    if (read_data) regs_[qmc5883l::kRegStatus] = 0;
    return I2cStatus::Ok;
}

}  // namespace glint::firmware::sim
