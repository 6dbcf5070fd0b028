// Register maps of the raw 9-axis pair: InvenSense MPU-6050 (gyro + accel; register map
// RM-MPU-6000A rev 4.2) and QST QMC5883L (magnetometer; datasheet rev 1.0, section 9). Shared by
// the drivers and the simulated chips (sim/raw_imu_models.hpp).
#pragma once

#include <cstdint>

namespace glint::firmware::mpu6050 {

inline constexpr std::uint8_t kAddress = 0x68;       // AD0 low
inline constexpr std::uint8_t kRegSmplrtDiv = 0x19;  // sample rate = 1 kHz / (1 + div) with DLPF on
inline constexpr std::uint8_t kRegConfig = 0x1A;     // DLPF_CFG bits 2:0
inline constexpr std::uint8_t kRegGyroConfig = 0x1B; // FS_SEL bits 4:3
inline constexpr std::uint8_t kRegAccelConfig = 0x1C;// AFS_SEL bits 4:3
inline constexpr std::uint8_t kRegAccelXoutH = 0x3B; // accel xyz, temp, gyro xyz: 7 x int16 BE
inline constexpr std::uint8_t kRegPwrMgmt1 = 0x6B;   // bit 7 reset, bit 6 sleep, bits 2:0 clock
inline constexpr std::uint8_t kRegWhoAmI = 0x75;     // reads kWhoAmI
inline constexpr std::uint8_t kWhoAmI = 0x68;
inline constexpr std::uint8_t kRegisterCount = 0x76;

inline constexpr std::uint8_t kPwrReset = 0x80;
inline constexpr std::uint8_t kPwrClockPllGyroX = 0x01;  // awake, PLL on the X gyro (datasheet advice)
inline constexpr std::uint8_t kConfigDlpf44Hz = 0x03;    // accel 44 Hz / gyro 42 Hz bandwidth
inline constexpr std::uint8_t kSmplrtDiv200Hz = 0x04;    // 1 kHz / 5
inline constexpr std::uint8_t kGyroFs500Dps = 0x08;      // FS_SEL 1: +-500 deg/s
inline constexpr std::uint8_t kAccelFs4G = 0x08;         // AFS_SEL 1: +-4 g
inline constexpr float kGyroLsbPerDps = 65.5f;           // at +-500 deg/s
inline constexpr float kAccelLsbPerG = 8192.0f;          // at +-4 g
inline constexpr std::uint32_t kResetTimeUs = 100'000;   // after DEVICE_RESET (RM section 4.28)
inline constexpr std::uint8_t kBurstSize = 14;           // 0x3B..0x48

}  // namespace glint::firmware::mpu6050

namespace glint::firmware::qmc5883l {

inline constexpr std::uint8_t kAddress = 0x0D;
inline constexpr std::uint8_t kRegDataX = 0x00;      // x, y, z int16 LE (0x00..0x05)
inline constexpr std::uint8_t kRegStatus = 0x06;     // bit 0 DRDY, bit 1 OVL, bit 2 DOR
inline constexpr std::uint8_t kRegControl1 = 0x09;   // OSR 7:6, RNG 5:4, ODR 3:2, MODE 1:0
inline constexpr std::uint8_t kRegControl2 = 0x0A;   // bit 7 SOFT_RST
inline constexpr std::uint8_t kRegSetReset = 0x0B;   // SET/RESET period, datasheet: write 0x01
inline constexpr std::uint8_t kRegChipId = 0x0D;     // reads kChipId
inline constexpr std::uint8_t kChipId = 0xFF;
inline constexpr std::uint8_t kRegisterCount = 0x0E;

inline constexpr std::uint8_t kStatusDrdy = 0x01;
inline constexpr std::uint8_t kStatusOverflow = 0x02;
inline constexpr std::uint8_t kSoftReset = 0x80;
// OSR 512 (00), range 8 gauss (01), ODR 100 Hz (10), continuous mode (01).
inline constexpr std::uint8_t kControl1Continuous100Hz8G = 0x19;
inline constexpr float kLsbPerUt = 30.0f;  // 3000 LSB/gauss at 8 G, 1 gauss = 100 uT
inline constexpr std::uint8_t kBurstSize = 7;  // 0x00..0x06 (data + status)

}  // namespace glint::firmware::qmc5883l
