// A whole simulated sensor board: trajectory -> ImuPhysics -> register models on a SimI2cBus ->
// the real drivers and the real Firmware, writing to whatever Uart and Clock it is given (a
// MemoryUart and a VirtualClock in tests, a PtyUart in the sim tool).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "firmware_bridge/firmware/bno055_imu.hpp"
#include "firmware_bridge/firmware/firmware.hpp"
#include "firmware_bridge/firmware/raw_nine_axis_imu.hpp"
#include "firmware_bridge/firmware/sim/bno055_model.hpp"
#include "firmware_bridge/firmware/sim/imu_physics.hpp"
#include "firmware_bridge/firmware/sim/raw_imu_models.hpp"
#include "firmware_bridge/firmware/sim/sim_hal.hpp"
#include "firmware_bridge/firmware/sim/sim_i2c_bus.hpp"

namespace glint::firmware::sim {

enum class ImuKind { Bno055, Raw };

// A window of the board clock during which the IMU's I2C address NACKs everything.
struct NackWindow {
    std::uint64_t start_us = 0;
    std::uint64_t end_us = 0;
};

struct SimBoardOptions {
    ImuKind imu = ImuKind::Bno055;
    SensorErrors errors;
    std::uint64_t seed = 1;
    FirmwareSettings settings;
    BoardInfo info{0x51A0B0A2, 1};
    std::vector<ButtonPress> presses;
    std::vector<NackWindow> imu_nacks;  // on the BNO055, or on the MPU-6050 (raw)
    std::vector<NackWindow> mag_nacks;  // raw IMU only: on the QMC5883L
    AxisRemap mounting;                 // chip axes on the board, for every chip (model and driver)
    std::uint64_t bno_power_on_us = 0;  // BNO055 boot starts here (it is silent for 650 ms)
};

class SimBoard {
public:
    SimBoard(const Trajectory& trajectory, SimBoardOptions options, Uart& uart, Clock& clock);

    void start() { firmware_->start(); }
    // One main-loop pass, then idle until the firmware's next deadline.
    void step() {
        poll();
        idle();
    }
    // The two halves of step(): what the pass sent leaves the board at the clock's time
    // between them, not after the idle (a recorder that stamped it after idle() put every
    // message one poll period late).
    void poll() { firmware_->poll(); }
    void idle() { clock_.wait_until_us(firmware_->next_wake_us()); }
    // Steps until the board clock reaches `end_us`.
    void run_until(std::uint64_t end_us) {
        while (clock_.now_us() < end_us) step();
    }

    Firmware& firmware() { return *firmware_; }
    ImuPhysics& physics() { return physics_; }
    SimGpio& gpio() { return gpio_; }
    SimI2cBus& bus() { return bus_; }
    ImuSource& imu() { return *imu_; }
    Bno055Model* bno055_model() { return bno_model_.get(); }  // null for the raw IMU

private:
    Clock& clock_;
    ImuPhysics physics_;
    SimI2cBus bus_;
    SimGpio gpio_;
    std::unique_ptr<Bno055Model> bno_model_;
    std::unique_ptr<Mpu6050Model> mpu_model_;
    std::unique_ptr<Qmc5883lModel> qmc_model_;
    std::unique_ptr<Bno055Imu> bno_driver_;
    std::unique_ptr<RawNineAxisImu> raw_driver_;
    ImuSource* imu_ = nullptr;
    std::unique_ptr<Firmware> firmware_;
};

}  // namespace glint::firmware::sim
