// Register map of the Bosch BNO055 (datasheet BST-BNO055-DS000, section 4), the subset the
// driver and the simulated chip (sim/bno055_model.hpp) use. Page 0 unless noted.
#pragma once

#include <cstdint>

namespace glint::firmware::bno055 {

inline constexpr std::uint8_t kAddressLow = 0x28;   // COM3 pin low (default on most boards)
inline constexpr std::uint8_t kAddressHigh = 0x29;  // COM3 pin high

inline constexpr std::uint8_t kRegChipId = 0x00;       // reads kChipId
inline constexpr std::uint8_t kChipId = 0xA0;
inline constexpr std::uint8_t kRegPageId = 0x07;       // 0 or 1, readable on both pages
inline constexpr std::uint8_t kRegAccData = 0x08;      // 3 x int16 LE, 1 m/s^2 = 100 LSB
inline constexpr std::uint8_t kRegMagData = 0x0E;      // 3 x int16 LE, 1 uT = 16 LSB
inline constexpr std::uint8_t kRegGyrData = 0x14;      // 3 x int16 LE, 1 deg/s = 16 LSB
inline constexpr std::uint8_t kRegEulData = 0x1A;      // heading, roll, pitch, 1 deg = 16 LSB
inline constexpr std::uint8_t kRegQuaData = 0x20;      // w, x, y, z int16 LE, 1.0 = 2^14 LSB
inline constexpr std::uint8_t kRegCalibStat = 0x35;    // sys 7:6, gyr 5:4, acc 3:2, mag 1:0
inline constexpr std::uint8_t kRegSysStatus = 0x39;    // 5 = fusion running
inline constexpr std::uint8_t kRegSysErr = 0x3A;
inline constexpr std::uint8_t kRegUnitSel = 0x3B;      // 0x00: m/s^2, deg/s, deg, Celsius, Windows
inline constexpr std::uint8_t kRegOprMode = 0x3D;      // low 4 bits: operating mode
inline constexpr std::uint8_t kRegPwrMode = 0x3E;      // 0x00 normal
inline constexpr std::uint8_t kRegSysTrigger = 0x3F;   // bit 5 RST_SYS
inline constexpr std::uint8_t kRegAxisMapConfig = 0x41;
inline constexpr std::uint8_t kRegAxisMapSign = 0x42;
inline constexpr std::uint8_t kRegisterCount = 0x80;   // registers per page

inline constexpr std::uint8_t kModeConfig = 0x00;
inline constexpr std::uint8_t kModeImu = 0x08;   // accel + gyro fusion, relative heading
inline constexpr std::uint8_t kModeNdof = 0x0C;  // 9-axis fusion with fast mag calibration

// Datasheet table 3-6, "switching time": CONFIGMODE -> any operating mode 7 ms, any operating
// mode -> CONFIGMODE 19 ms. The chip ignores (or mis-handles) transfers in between.
inline constexpr std::uint32_t kConfigToOperatingUs = 7'000;
inline constexpr std::uint32_t kOperatingToConfigUs = 19'000;
// Power-on / RST_SYS to the first I2C answer: 650 ms typical (datasheet table 1-2).
inline constexpr std::uint32_t kBootTimeUs = 650'000;

inline constexpr float kAccLsbPerMs2 = 100.0f;
inline constexpr float kMagLsbPerUt = 16.0f;
inline constexpr float kGyrLsbPerDps = 16.0f;
inline constexpr float kQuaLsb = 16384.0f;  // 2^14

// The burst the driver reads every sample: accel, mag, gyro, euler, quaternion (0x08..0x27).
inline constexpr std::uint8_t kBurstFirst = kRegAccData;
inline constexpr std::uint8_t kBurstSize = kRegQuaData + 8 - kRegAccData;  // 32 bytes
// The status block read ten times a second: CALIB_STAT .. OPR_MODE (0x35..0x3D).
inline constexpr std::uint8_t kStatusFirst = kRegCalibStat;
inline constexpr std::uint8_t kStatusSize = kRegOprMode - kRegCalibStat + 1;  // 9 bytes

}  // namespace glint::firmware::bno055
