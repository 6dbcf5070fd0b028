// The BNO055 driver against the register model: probe (with page 1 left selected), the mode
// switch with the datasheet's delays (the model NACKs early transfers), quaternion read and
// conversion to the Glint world frame (also with a remapped mounting), raw data, calibration,
// recovery from NACKs and from a chip reset.
#include <gtest/gtest.h>

#include <array>

#include "firmware_bridge/firmware/bno055_imu.hpp"
#include "firmware_bridge/firmware/bno055_registers.hpp"
#include "firmware_bridge/firmware/sim/bno055_model.hpp"
#include "firmware_bridge/firmware/sim/sim_hal.hpp"
#include "firmware_test_support.hpp"

namespace glint::firmware {
namespace {

using test::angle_deg;
using test::kDeg;

constexpr std::uint64_t kStepUs = 5000;

struct Rig {
    explicit Rig(sim::Trajectory t, sim::SensorErrors errors = sim::SensorErrors::none(), AxisRemap mounting = {},
                 std::uint8_t initial_page = 0)
        : trajectory(std::move(t)), physics(trajectory, errors, 1), bus(clock),
          model(physics, [&] {
              sim::Bno055ModelConfig c;
              c.mounting = mounting;
              c.initial_page = initial_page;
              return c;
          }()),
          driver(bus, [&] {
              Bno055Config c;
              c.mounting = mounting;
              return c;
          }()) {
        bus.attach(bno055::kAddressLow, model);
    }
    // Polls every 5 ms until a sample with an orientation arrives; returns false at the limit.
    bool poll_until_fused(ImuReading& reading, std::uint64_t limit_us = 2'000'000) {
        const std::uint64_t end = clock.now_us() + limit_us;
        while (clock.now_us() < end) {
            const ImuStatus s = driver.poll(clock.now_us(), reading);
            if (s == ImuStatus::Ok && reading.has_orientation) return true;
            clock.advance_us(kStepUs);
        }
        return false;
    }

    sim::Trajectory trajectory;
    sim::VirtualClock clock;
    sim::ImuPhysics physics;
    sim::SimI2cBus bus;
    sim::Bno055Model model;
    Bno055Imu driver;
};

TEST(Bno055, QuaternionRegistersConvertWithScale2To14) {
    // w = 0.5, x = -0.5, y = 0.5, z = -0.5 in int16 LE at 1/16384.
    const std::array<std::uint8_t, 8> regs{0x00, 0x20, 0x00, 0xE0, 0x00, 0x20, 0x00, 0xE0};
    const Quatf q = Bno055Imu::quaternion_from_registers(regs.data());
    EXPECT_FLOAT_EQ(q.w, 0.5f);
    EXPECT_FLOAT_EQ(q.x, -0.5f);
    EXPECT_FLOAT_EQ(q.y, 0.5f);
    EXPECT_FLOAT_EQ(q.z, -0.5f);
    const CalibrationLevels c = Bno055Imu::calibration_from_register(0b11'10'01'00);
    EXPECT_EQ(c, (CalibrationLevels{3, 2, 1, 0}));
}

TEST(Bno055, ProbesSelectsPage0AndSwitchesToNdofWithDatasheetDelays) {
    Rig rig(sim::Trajectory::builtin("static"), sim::SensorErrors::none(), {}, /*initial_page=*/1);
    ImuReading reading;
    // Boot: 650 ms of silence is "starting", not a fault.
    EXPECT_EQ(rig.driver.poll(0, reading), ImuStatus::Starting);
    ASSERT_TRUE(rig.poll_until_fused(reading));
    EXPECT_EQ(rig.model.operating_mode(), bno055::kModeNdof);
    EXPECT_EQ(rig.driver.state(), Bno055Imu::State::Running);
    // The model NACKs transfers during a mode switch: the driver never made one.
    EXPECT_EQ(rig.model.transfers_during_switch(), rig.bus.nacks());
    EXPECT_GE(rig.model.mode_switches(), 1u);
    // Boot NACKs only (before 650 ms): after the boot no transfer failed.
    EXPECT_LE(rig.clock.now_us(), bno055::kBootTimeUs + 200'000);
}

TEST(Bno055, OrientationIsSensorToGlintWorld) {
    Rig rig(sim::Trajectory::builtin("static"));
    ImuReading reading;
    ASSERT_TRUE(rig.poll_until_fused(reading));
    const Quatd truth = rig.trajectory.at(rig.clock.now_us()).world_from_sensor;
    // 2^-14 register resolution: well under 0.05 deg.
    EXPECT_LT(angle_deg(quat_cast<double>(reading.world_from_sensor), truth), 0.05);
    // Raw data in the sensor frame: gravity reaction along the sensor's view of world up.
    const Vec3d up_sensor = truth.rotate_inverse(Vec3d{0, 1, 0});
    EXPECT_NEAR(reading.accel_m_s2.x, 9.80665 * up_sensor.x, 0.01);
    EXPECT_NEAR(reading.accel_m_s2.y, 9.80665 * up_sensor.y, 0.01);
    EXPECT_NEAR(reading.accel_m_s2.z, 9.80665 * up_sensor.z, 0.01);
    const Vec3d mag = truth.rotate_inverse(sim::kEarthFieldWorldUt);
    EXPECT_NEAR(reading.mag_ut.y, mag.y, 0.07);
    EXPECT_EQ(reading.raw_valid, 0x07);
}

TEST(Bno055, MountingRemapStillGivesTheBoardOrientation) {
    // Chip turned on the board: sensor x = chip y, sensor y = -chip x, z = z.
    AxisRemap mounting;
    mounting.source[0] = 1;
    mounting.source[1] = 0;
    mounting.sign[1] = -1;
    Rig rig(sim::Trajectory::builtin("yaw-sweep"), sim::SensorErrors::none(), mounting);
    ImuReading reading;
    ASSERT_TRUE(rig.poll_until_fused(reading));
    for (int i = 0; i < 400; ++i) {  // 2 s of motion
        rig.clock.advance_us(kStepUs);
        ASSERT_EQ(rig.driver.poll(rig.clock.now_us(), reading), ImuStatus::Ok);
    }
    // The chip's output is 100 Hz: compare with the truth at the last 10 ms output tick.
    const Quatd truth = rig.trajectory.at(reading.timestamp_us - reading.timestamp_us % 10'000).world_from_sensor;
    EXPECT_LT(angle_deg(quat_cast<double>(reading.world_from_sensor), truth), 0.5);
}

TEST(Bno055, CalibrationStatusFollowsTheChip) {
    Rig rig(sim::Trajectory::builtin("static"));
    ImuReading reading;
    ASSERT_TRUE(rig.poll_until_fused(reading));
    EXPECT_LT(reading.calibration.system, 3);
    for (int i = 0; i < 1200; ++i) {  // 6 s: the model's mag reaches 3 after 5 s
        rig.clock.advance_us(kStepUs);
        ASSERT_EQ(rig.driver.poll(rig.clock.now_us(), reading), ImuStatus::Ok);
    }
    EXPECT_EQ(reading.calibration, (CalibrationLevels{3, 3, 3, 3}));
}

TEST(Bno055, RecoversFromNacksByProbingAgain) {
    Rig rig(sim::Trajectory::builtin("static"));
    ImuReading reading;
    ASSERT_TRUE(rig.poll_until_fused(reading));
    const std::uint32_t probes_before = rig.driver.probes();
    const std::uint64_t t0 = rig.clock.now_us();
    rig.bus.add_nack_window(bno055::kAddressLow, t0 + 10'000, t0 + 300'000);
    rig.clock.advance_us(10'000);
    EXPECT_EQ(rig.driver.poll(rig.clock.now_us(), reading), ImuStatus::ReadFailed);
    rig.clock.advance_us(kStepUs);
    EXPECT_EQ(rig.driver.poll(rig.clock.now_us(), reading), ImuStatus::NotResponding);
    ASSERT_TRUE(rig.poll_until_fused(reading));
    EXPECT_GE(rig.clock.now_us(), t0 + 300'000);
    EXPECT_GT(rig.driver.probes(), probes_before + 1);  // probed during the window and after
    EXPECT_EQ(rig.model.operating_mode(), bno055::kModeNdof);
    EXPECT_LT(angle_deg(quat_cast<double>(reading.world_from_sensor),
                        rig.trajectory.at(rig.clock.now_us()).world_from_sensor), 0.05);
}

TEST(Bno055, NoticesASilentChipResetAndReconfigures) {
    Rig rig(sim::Trajectory::builtin("static"));
    ImuReading reading;
    ASSERT_TRUE(rig.poll_until_fused(reading));
    rig.model.reset(rig.clock.now_us());  // brown-out: reboots into CONFIGMODE
    ASSERT_TRUE(rig.poll_until_fused(reading));  // the status read sees CONFIGMODE and re-probes
    EXPECT_EQ(rig.model.operating_mode(), bno055::kModeNdof);
}

TEST(Bno055, ImuModeDropsTheMagnetometer) {
    Rig rig(sim::Trajectory::builtin("static"));
    ImuReading reading;
    ASSERT_TRUE(rig.driver.set_mode(protocol::FusionMode::Imu));
    EXPECT_FALSE(rig.driver.set_mode(protocol::FusionMode::Off));
    ASSERT_TRUE(rig.poll_until_fused(reading));
    EXPECT_EQ(rig.model.operating_mode(), bno055::kModeImu);
    EXPECT_EQ(reading.raw_valid, 0x03);
}

}  // namespace
}  // namespace glint::firmware
