// What the firmware main loop needs from an IMU, whichever chip delivers it: a BNO055 with
// on-chip fusion (bno055_imu.hpp) or a raw 9-axis IMU fused on the board (raw_nine_axis_imu.hpp).
#pragma once

#include <cstdint>

#include "firmware_bridge/firmware/rotation.hpp"
#include "firmware_bridge/protocol/messages.hpp"

namespace glint::firmware {

struct CalibrationLevels {
    std::uint8_t system = 0;  // 0 (uncalibrated) .. 3 (fully), as in FusionStatus
    std::uint8_t gyro = 0;
    std::uint8_t accel = 0;
    std::uint8_t mag = 0;
    friend bool operator==(const CalibrationLevels&, const CalibrationLevels&) = default;
};

// One sample, everything in the board's sensor frame (axes printed on the board).
struct ImuReading {
    std::uint64_t timestamp_us = 0;  // board clock when the sample was read
    bool has_orientation = false;    // fusion produced an estimate
    Quatf world_from_sensor;         // rotation sensor -> world (+Y up, -Z north/forward)
    std::uint8_t raw_valid = 0;      // protocol::raw_valid bits of the three vectors below
    Vec3f gyro_rad_s;
    Vec3f accel_m_s2;                // specific force: (0, +9.81, 0) at rest with +Y up
    Vec3f mag_ut;                    // microtesla
    CalibrationLevels calibration;
    Vec3f gyro_bias_rad_s;           // current bias estimate (0 when the chip does not say)
};

enum class ImuStatus : std::uint8_t {
    Ok = 0,         // `reading` holds a new sample
    Degraded,       // `reading` holds a new sample, but a secondary sensor failed (e.g. the
                    // magnetometer: fusion runs without it); last_fault_sensors() says which
    Starting,       // probe/configuration in progress (mode switch delays); try again later
    ReadFailed,     // a transfer failed; the driver will re-probe on the next call
    NotResponding,  // the chip does not answer its probe
};

class ImuSource {
public:
    // capability bits this IMU gives the board (gyro, accel, mag, fusion, raw).
    virtual std::uint32_t capabilities() const = 0;
    // Requests a fusion mode; false when this IMU cannot run it (nothing changes).
    virtual bool set_mode(protocol::FusionMode mode) = 0;
    virtual protocol::FusionMode mode() const = 0;
    // Fusion gains of board-side fusion (has_gains() false: the chip fuses, no gains here).
    virtual bool has_gains() const = 0;
    virtual bool set_gains(float kp, float ki) = 0;  // false: out of range, nothing changed
    virtual void gains(float& kp, float& ki) const = 0;
    // Advances probing/configuration and, when running, reads one sample at `now_us` (board
    // clock). Never blocks: mode-switch delays are waited out across calls.
    virtual ImuStatus poll(std::uint64_t now_us, ImuReading& reading) = 0;
    // The sensors (protocol::capability bits) concerned by the last failing poll().
    virtual std::uint32_t last_fault_sensors() const = 0;

protected:
    ~ImuSource() = default;
};

}  // namespace glint::firmware
