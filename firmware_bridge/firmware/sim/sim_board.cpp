// Simulated sensor board: see sim_board.hpp.
#include "firmware_bridge/firmware/sim/sim_board.hpp"

#include "firmware_bridge/firmware/bno055_registers.hpp"

namespace glint::firmware::sim {

SimBoard::SimBoard(const Trajectory& trajectory, SimBoardOptions options, Uart& uart, Clock& clock)
    : clock_(clock), physics_(trajectory, options.errors, options.seed), bus_(clock), gpio_(clock) {
    for (const ButtonPress& p : options.presses) gpio_.add_press(p);
    if (options.imu == ImuKind::Bno055) {
        Bno055ModelConfig model_config;
        model_config.mounting = options.mounting;
        model_config.power_on_us = options.bno_power_on_us;
        bno_model_ = std::make_unique<Bno055Model>(physics_, model_config);
        bus_.attach(bno055::kAddressLow, *bno_model_);
        for (const NackWindow& w : options.imu_nacks) bus_.add_nack_window(bno055::kAddressLow, w.start_us, w.end_us);
        Bno055Config driver_config;
        driver_config.mounting = options.mounting;
        bno_driver_ = std::make_unique<Bno055Imu>(bus_, driver_config);
        imu_ = bno_driver_.get();
    } else {
        mpu_model_ = std::make_unique<Mpu6050Model>(physics_, options.mounting);
        qmc_model_ = std::make_unique<Qmc5883lModel>(physics_, options.mounting);
        bus_.attach(mpu6050::kAddress, *mpu_model_);
        bus_.attach(qmc5883l::kAddress, *qmc_model_);
        for (const NackWindow& w : options.imu_nacks) bus_.add_nack_window(mpu6050::kAddress, w.start_us, w.end_us);
        for (const NackWindow& w : options.mag_nacks) bus_.add_nack_window(qmc5883l::kAddress, w.start_us, w.end_us);
        RawNineAxisConfig driver_config;
        driver_config.gyro_accel_mounting = options.mounting;
        driver_config.mag_mounting = options.mounting;
        raw_driver_ = std::make_unique<RawNineAxisImu>(bus_, driver_config);
        imu_ = raw_driver_.get();
    }
    firmware_ = std::make_unique<Firmware>(Hal{bus_, uart, clock_, gpio_}, *imu_, options.info, options.settings);
}

}  // namespace glint::firmware::sim
