// The MPU-6050 + QMC5883L driver against their register models, and the whole raw path
// (registers -> driver -> Mahony fusion) on simulated trajectories. Bounds asserted:
//   - configuration registers hold what the driver documents (+-500 deg/s, +-4 g, 8 G, 100 Hz);
//   - perfect sensors, static: raw conversions within one LSB of the truth;
//   - default noise (gyro 0.057 deg/s rms, bias ~0.7 deg/s, accel 0.02 m/s^2, mag 0.3 uT),
//     "kiosk" trajectory, 60 s: orientation error < 2 deg at every sample after 15 s;
//   - the magnetometer NACKing: samples keep coming (Degraded), fusion runs on without it, and
//     the magnetometer is taken back once it answers.
#include <gtest/gtest.h>

#include <algorithm>

#include "firmware_bridge/firmware/raw_imu_registers.hpp"
#include "firmware_bridge/firmware/raw_nine_axis_imu.hpp"
#include "firmware_bridge/firmware/sim/raw_imu_models.hpp"
#include "firmware_bridge/firmware/sim/sim_hal.hpp"
#include "firmware_test_support.hpp"

namespace glint::firmware {
namespace {

using test::angle_deg;
using test::kDeg;

constexpr std::uint64_t kStepUs = 5000;

struct RawRig {
    RawRig(sim::Trajectory t, sim::SensorErrors errors)
        : trajectory(std::move(t)), physics(trajectory, errors, 42), bus(clock), mpu(physics), qmc(physics),
          driver(bus) {
        bus.attach(mpu6050::kAddress, mpu);
        bus.attach(qmc5883l::kAddress, qmc);
    }
    ImuStatus step(ImuReading& reading) {
        clock.advance_us(kStepUs);
        return driver.poll(clock.now_us(), reading);
    }

    sim::Trajectory trajectory;
    sim::VirtualClock clock;
    sim::ImuPhysics physics;
    sim::SimI2cBus bus;
    sim::Mpu6050Model mpu;
    sim::Qmc5883lModel qmc;
    RawNineAxisImu driver;
};

TEST(RawImu, ConfiguresTheChipsAndConvertsUnits) {
    RawRig rig(sim::Trajectory::builtin("static"), sim::SensorErrors::none());
    ImuReading reading;
    EXPECT_EQ(rig.driver.poll(0, reading), ImuStatus::Starting);  // MPU-6050 reset: 100 ms
    int ok = 0;
    for (int i = 0; i < 100; ++i) ok += rig.step(reading) == ImuStatus::Ok ? 1 : 0;
    ASSERT_GT(ok, 70);
    EXPECT_EQ(rig.mpu.reg(mpu6050::kRegGyroConfig), 0x08);
    EXPECT_EQ(rig.mpu.reg(mpu6050::kRegAccelConfig), 0x08);
    EXPECT_EQ(rig.mpu.reg(mpu6050::kRegPwrMgmt1), 0x01);
    EXPECT_EQ(rig.mpu.reg(mpu6050::kRegSmplrtDiv), 0x04);
    EXPECT_TRUE(rig.driver.mag_running());

    const Quatd truth = rig.trajectory.at(0).world_from_sensor;
    const Vec3d accel = truth.rotate_inverse(Vec3d{0, 9.80665, 0});
    const double accel_lsb = 9.80665 / 8192;
    EXPECT_NEAR(reading.accel_m_s2.x, accel.x, accel_lsb);
    EXPECT_NEAR(reading.accel_m_s2.y, accel.y, accel_lsb);
    EXPECT_NEAR(reading.accel_m_s2.z, accel.z, accel_lsb);
    const Vec3d mag = truth.rotate_inverse(sim::kEarthFieldWorldUt);
    EXPECT_NEAR(reading.mag_ut.x, mag.x, 1.0 / 30);
    EXPECT_NEAR(reading.mag_ut.y, mag.y, 1.0 / 30);
    EXPECT_NEAR(reading.mag_ut.z, mag.z, 1.0 / 30);
    EXPECT_EQ(reading.raw_valid, 0x07);
    ASSERT_TRUE(reading.has_orientation);
    EXPECT_LT(angle_deg(quat_cast<double>(reading.world_from_sensor), truth), 0.2);
}

TEST(RawImu, FusionAccuracyOnKioskTrajectory) {
    RawRig rig(sim::Trajectory::builtin("kiosk"), sim::SensorErrors{});
    ImuReading reading;
    double worst_after_settle = 0;
    int samples = 0;
    for (std::uint64_t t = 0; t < 60'000'000; t += kStepUs) {
        if (rig.step(reading) != ImuStatus::Ok || !reading.has_orientation) continue;
        ++samples;
        if (rig.clock.now_us() < 15'000'000) continue;
        // The MPU-6050 model samples at 200 Hz on its own 5 ms grid: compare at that time.
        const std::uint64_t sampled_at = rig.clock.now_us() - rig.clock.now_us() % 5000;
        worst_after_settle = std::max(worst_after_settle,
                                      angle_deg(quat_cast<double>(reading.world_from_sensor),
                                                rig.trajectory.at(sampled_at).world_from_sensor));
    }
    EXPECT_GT(samples, 11'000);
    EXPECT_LT(worst_after_settle, 2.0);
}

TEST(RawImu, RunsOnWithoutAFailedMagnetometerAndTakesItBack) {
    RawRig rig(sim::Trajectory::builtin("static"), sim::SensorErrors{});
    rig.bus.add_nack_window(qmc5883l::kAddress, 2'000'000, 4'000'000);
    ImuReading reading;
    int degraded = 0, ok_without_mag = 0;
    bool mag_back = false;
    while (rig.clock.now_us() < 7'000'000) {
        const ImuStatus s = rig.step(reading);
        if (s == ImuStatus::Degraded) {
            ++degraded;
            EXPECT_EQ(rig.driver.last_fault_sensors(), protocol::capability::kMag);
        }
        if (rig.clock.now_us() > 2'100'000 && rig.clock.now_us() < 4'000'000 && s == ImuStatus::Ok) {
            ++ok_without_mag;
            EXPECT_EQ(reading.raw_valid, 0x03);  // gyro + accel only
            EXPECT_EQ(reading.calibration.mag, 0);
        }
        if (rig.clock.now_us() > 5'100'000) mag_back = mag_back || (reading.raw_valid & 0x04) != 0;
    }
    EXPECT_GE(degraded, 2);  // the failing read and at least one failed re-probe (1 s apart)
    EXPECT_GT(ok_without_mag, 300);
    EXPECT_TRUE(mag_back);
    EXPECT_LT(angle_deg(quat_cast<double>(reading.world_from_sensor),
                        rig.trajectory.at(rig.clock.now_us()).world_from_sensor), 1.0);
}

// A magnetometer that answers but stops converting (a brown-out leaves the QMC5883L in standby)
// is found within the silence limit (100 ms), reported, and restarted; meanwhile its last sample
// is neither fused nor reported as a fresh reading for long.
TEST(RawImu, ASilentMagnetometerIsRestarted) {
    RawRig rig(sim::Trajectory::builtin("static"), sim::SensorErrors{});
    ImuReading reading;
    bool put_in_standby = false, mag_back = false;
    int degraded = 0;
    std::uint64_t first_fault_us = 0;
    while (rig.clock.now_us() < 4'000'000) {
        if (!put_in_standby && rig.clock.now_us() >= 2'000'000) {
            ASSERT_EQ(rig.qmc.write_reg(qmc5883l::kRegControl1, 0x00, rig.clock.now_us()), I2cStatus::Ok);
            put_in_standby = true;
        }
        const ImuStatus s = rig.step(reading);
        if (s == ImuStatus::Degraded) {
            ++degraded;
            if (first_fault_us == 0) first_fault_us = rig.clock.now_us();
            EXPECT_EQ(rig.driver.last_fault_sensors(), protocol::capability::kMag);
        }
        if (rig.clock.now_us() > 2'500'000) mag_back = mag_back || (reading.raw_valid & 0x04) != 0;
    }
    EXPECT_GE(degraded, 1);
    EXPECT_GE(first_fault_us, 2'100'000u);  // not before the silence limit
    EXPECT_LE(first_fault_us, 2'150'000u);
    EXPECT_TRUE(mag_back);  // restarted: continuous mode again
    std::uint8_t control = 0;
    ASSERT_EQ(rig.bus.read_regs(qmc5883l::kAddress, qmc5883l::kRegControl1, {&control, 1}), I2cStatus::Ok);
    EXPECT_EQ(control, qmc5883l::kControl1Continuous100Hz8G);
    EXPECT_LT(angle_deg(quat_cast<double>(reading.world_from_sensor),
                        rig.trajectory.at(rig.clock.now_us()).world_from_sensor), 1.0);
}

TEST(RawImu, GyroAccelNacksAreReadFailuresThenRecovered) {
    RawRig rig(sim::Trajectory::builtin("static"), sim::SensorErrors{});
    rig.bus.add_nack_window(mpu6050::kAddress, 1'000'000, 1'500'000);
    ImuReading reading;
    int failed = 0, not_responding = 0;
    while (rig.clock.now_us() < 2'500'000) {
        const ImuStatus s = rig.step(reading);
        failed += s == ImuStatus::ReadFailed ? 1 : 0;
        not_responding += s == ImuStatus::NotResponding ? 1 : 0;
    }
    EXPECT_EQ(failed, 1);
    EXPECT_GT(not_responding, 0);
    EXPECT_TRUE(reading.has_orientation);
    EXPECT_EQ(rig.mpu.reg(mpu6050::kRegGyroConfig), 0x08);  // configured again after its reset
}

TEST(RawImu, GainsAreRangeChecked) {
    RawRig rig(sim::Trajectory::builtin("static"), sim::SensorErrors{});
    EXPECT_TRUE(rig.driver.set_gains(2.0f, 0.2f));
    EXPECT_FALSE(rig.driver.set_gains(-1.0f, 0.2f));
    float kp = 0, ki = 0;
    rig.driver.gains(kp, ki);
    EXPECT_EQ(kp, 2.0f);
    EXPECT_EQ(ki, 0.2f);
}

}  // namespace
}  // namespace glint::firmware
