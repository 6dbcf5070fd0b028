// BNO055 register model: see bno055_model.hpp.
#include "firmware_bridge/firmware/sim/bno055_model.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "firmware_bridge/firmware/bno055_registers.hpp"
#include "firmware_bridge/firmware/register_bytes.hpp"

namespace glint::firmware::sim {
namespace {

std::int16_t saturate_i16(double v) {
    const double r = std::round(v);
    return static_cast<std::int16_t>(std::clamp(r, -32768.0, 32767.0));
}

void put_vec(std::uint8_t* p, Vec3d v, double lsb_per_unit) {
    put_int16_le(p, saturate_i16(v.x * lsb_per_unit));
    put_int16_le(p + 2, saturate_i16(v.y * lsb_per_unit));
    put_int16_le(p + 4, saturate_i16(v.z * lsb_per_unit));
}

constexpr std::uint64_t kFusionPeriodUs = 10'000;  // 100 Hz fusion output

}  // namespace

Bno055Model::Bno055Model(ImuPhysics& physics, Bno055ModelConfig config)
    : physics_(physics), config_(config) {
    reset(config_.power_on_us);
    page_ = config_.initial_page & 1;
    pages_[0][bno055::kRegPageId] = pages_[1][bno055::kRegPageId] = page_;
}

void Bno055Model::reset(std::uint64_t now_us) {
    pages_ = {};
    auto& p0 = pages_[0];
    p0[bno055::kRegChipId] = bno055::kChipId;
    p0[0x01] = 0xFB;  // ACC_ID
    p0[0x02] = 0x32;  // MAG_ID
    p0[0x03] = 0x0F;  // GYR_ID
    p0[bno055::kRegUnitSel] = 0x80;
    p0[bno055::kRegAxisMapConfig] = 0x24;  // P1: x->X, y->Y, z->Z
    page_ = 0;
    mode_ = bno055::kModeConfig;
    silent_until_us_ = now_us + bno055::kBootTimeUs;
    last_output_tick_ = UINT64_MAX;
}

// The chip does not answer while it boots or switches mode; a transfer then is NACKed.
bool Bno055Model::busy(std::uint64_t now_us) {
    if (now_us >= silent_until_us_) return false;
    ++transfers_during_switch_;
    return true;
}

I2cStatus Bno055Model::write_reg(std::uint8_t reg, std::uint8_t value, std::uint64_t now_us) {
    if (busy(now_us)) return I2cStatus::Nack;
    if (reg >= bno055::kRegisterCount) return I2cStatus::Ok;  // ignored, as on the chip
    if (reg == bno055::kRegPageId) {
        page_ = value & 1;
        pages_[0][reg] = pages_[1][reg] = page_;
        return I2cStatus::Ok;
    }
    if (page_ != 0) return I2cStatus::Ok;  // page-1 configuration is not modelled
    if (reg == bno055::kRegSysTrigger && (value & 0x20) != 0) {
        reset(now_us);
        return I2cStatus::Ok;
    }
    if (reg == bno055::kRegOprMode) {
        const std::uint8_t next = value & 0x0F;
        if (next != mode_) {
            ++mode_switches_;
            silent_until_us_ = now_us + (next == bno055::kModeConfig ? bno055::kOperatingToConfigUs
                                                                     : bno055::kConfigToOperatingUs);
            mode_ = next;
            fusion_since_us_ = silent_until_us_;
            last_output_tick_ = UINT64_MAX;
            // Entering a mode clears the outputs: fusion has produced nothing yet.
            std::fill(pages_[0].begin() + bno055::kRegAccData, pages_[0].begin() + bno055::kRegCalibStat + 1, 0);
        }
        pages_[0][reg] = value;
        return I2cStatus::Ok;
    }
    // Configuration registers are writable in CONFIGMODE only (datasheet 3.3).
    if (mode_ == bno055::kModeConfig) pages_[0][reg] = value;
    return I2cStatus::Ok;
}

void Bno055Model::refresh_outputs(std::uint64_t now_us) {
    if (mode_ != bno055::kModeNdof && mode_ != bno055::kModeImu) return;  // outputs frozen
    const std::uint64_t tick = (now_us - fusion_since_us_) / kFusionPeriodUs;
    if (tick == last_output_tick_) return;
    last_output_tick_ = tick;
    const std::uint64_t t = fusion_since_us_ + tick * kFusionPeriodUs;
    const SensorReadings r = physics_.read(t);
    auto& p0 = pages_[0];
    const AxisRemap& m = config_.mounting;
    const std::uint8_t unit = p0[bno055::kRegUnitSel];
    const double acc_lsb = (unit & 0x01) != 0 ? 1000.0 / kGravity : 100.0;  // mg : m/s^2
    const double gyr_lsb = (unit & 0x02) != 0 ? 900.0 : 16.0 * 180.0 / std::numbers::pi;  // rps : dps
    put_vec(&p0[bno055::kRegAccData], m.to_chip(r.accel_m_s2), acc_lsb);
    // The chip's fusion removes its gyro bias: the gyro registers hold the calibrated rate.
    put_vec(&p0[bno055::kRegGyrData], m.to_chip(r.gyro_rad_s - r.gyro_bias_rad_s), gyr_lsb);
    const bool ndof = mode_ == bno055::kModeNdof;
    put_vec(&p0[bno055::kRegMagData], ndof ? m.to_chip(r.mag_ut) : Vec3d{}, 16.0);

    // Fusion output: chip -> ENU = (ENU <- Glint world) (world <- sensor) (sensor <- chip).
    const Quatd enu_from_world = quat_cast<double>(glint_world_from_enu()).conj();
    const Quatd sensor_from_chip = quat_cast<double>(m.sensor_to_chip()).conj();
    // In IMU mode the chip's heading is relative to its start; the model keeps the true
    // heading, which is one valid choice of that reference.
    const Quatd q = normalized(enu_from_world * r.truth.world_from_sensor * sensor_from_chip);
    put_int16_le(&p0[bno055::kRegQuaData + 0], saturate_i16(q.w * 16384.0));
    put_int16_le(&p0[bno055::kRegQuaData + 2], saturate_i16(q.x * 16384.0));
    put_int16_le(&p0[bno055::kRegQuaData + 4], saturate_i16(q.y * 16384.0));
    put_int16_le(&p0[bno055::kRegQuaData + 6], saturate_i16(q.z * 16384.0));

    const double in_fusion_s = static_cast<double>(now_us - fusion_since_us_) * 1e-6;
    const auto level = [&](double full_s) {
        return static_cast<std::uint8_t>(std::min(3.0, std::floor(3.0 * in_fusion_s / full_s)));
    };
    const std::uint8_t gyr = level(config_.gyro_calibrated_s);
    const std::uint8_t acc = level(config_.accel_calibrated_s);
    const std::uint8_t mag = ndof ? level(config_.mag_calibrated_s) : 0;
    const std::uint8_t sys = std::min({gyr, acc, ndof ? mag : std::uint8_t{3}});
    p0[bno055::kRegCalibStat] = static_cast<std::uint8_t>(sys << 6 | gyr << 4 | acc << 2 | mag);
    p0[bno055::kRegSysStatus] = 5;  // sensor fusion algorithm running
}

I2cStatus Bno055Model::read_regs(std::uint8_t first_reg, std::span<std::uint8_t> out, std::uint64_t now_us) {
    if (busy(now_us)) return I2cStatus::Nack;
    refresh_outputs(now_us);
    read_register_file(std::span(pages_[page_]).first(bno055::kRegisterCount), first_reg, out);
    return I2cStatus::Ok;
}

}  // namespace glint::firmware::sim
