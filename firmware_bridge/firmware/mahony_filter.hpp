// Attitude and heading fusion of a raw 9-axis IMU on the board: Mahony's explicit
// complementary filter with gyro-bias estimation (integral feedback), float only, no heap.
//
// Source: R. Mahony, T. Hamel, J.-M. Pflimlin, "Nonlinear Complementary Filters on the Special
// Orthogonal Group", IEEE TAC 53(5), 2008, eq. (32) "explicit complementary filter with bias
// correction":
//
//   e      = sum_i k_i  v_i x v^_i          v_i measured direction, v^_i = R^T v0_i predicted
//   dq/dt  = 1/2 q (x) (0, w_gyro - b^ + kP e)
//   db^/dt = -kI e
//
// with R (q) the rotation sensor -> world. In discrete time each step's measurements are of the
// step's own time, so e is taken against the estimate carried to that time by the gyro
// (q (x) exp((w_gyro - b^) dt / 2)), not against the previous step's: that one's feedback settles
// one sample early (5 ms at 200 Hz, found 2026-12-08). Two changes from the paper, both so a
// magnetometer can never tilt the estimate:
//   - the accelerometer term uses v0 = world up (0, 1, 0): at rest an accelerometer measures
//     the specific force +g up;
//   - the magnetometer term only corrects heading: the measured field is rotated to the world,
//     its horizontal part h is compared with north n = (0, 0, -1), and the error h x n (a vertical
//     vector, |.| = sin of the heading error) is rotated back to the sensor frame.
// A field sample is passed once, when the chip has a new one, and its heading term is weighted
// by the time since the last one (at most 50 ms, and at most what corrects half the heading error
// at once, kP gap <= 1/2), so that a magnetometer slower than the gyro keeps the heading's time
// constant and is not fused again while it ages.
// Samples whose accelerometer norm is far from g (the board is being accelerated) or whose field
// norm or dip angle is far from the reference learned at start (a magnet, a steel door) are
// left out of the correction, so the gyro carries the estimate through them. The bias is only
// integrated while the error is small (anti-windup, see MahonyLimits::bias_error_limit).
#pragma once

#include "firmware_bridge/firmware/rotation.hpp"

namespace glint::firmware {

struct MahonyGains {
    float kp = 1.0f;   // proportional gain, rad/s per unit error (time constant ~ 1/kp = 1 s)
    float ki = 0.1f;   // integral gain, rad/s^2 per unit error (bias time constant ~ kp/ki = 10 s)
    float mag_weight = 1.0f;  // weight of the heading error relative to the tilt error
};

struct MahonyLimits {
    float gravity_m_s2 = 9.80665f;
    float accel_tolerance = 0.1f;        // |(|a| - g)| / g beyond which accel is not trusted
    float mag_norm_tolerance = 0.2f;     // relative change of |m| beyond which mag is not trusted
    float mag_dip_tolerance_rad = 0.17f; // change of the dip angle (~10 deg) likewise
    float max_bias_rad_s = 0.35f;        // clamp of each bias component (MPU-6050: +-20 deg/s ZRO)
    // The bias is integrated only while the error is small (|e| ~ sin of the angle, 0.1 ~ 6 deg):
    // a large error is a transient (start, a wrong set_orientation), not bias, and integrating
    // it would wind the bias estimate up and take kp/ki seconds to unwind.
    float bias_error_limit = 0.1f;
    float mag_reference_time_s = 30.0f;  // time constant of the reference field's slow update
};

class MahonyFilter {
public:
    explicit MahonyFilter(MahonyGains gains = {}, MahonyLimits limits = {})
        : gains_(gains), limits_(limits) {}

    // Back to "no estimate": the next update() initialises from accel (and mag) directly.
    void reset();
    // Sets the estimate (e.g. a test starting from a wrong attitude); keeps the bias estimate.
    void set_orientation(Quatf world_from_sensor);
    void set_gains(MahonyGains gains) { gains_ = gains; }
    const MahonyGains& gains() const { return gains_; }

    // One step. gyro in rad/s, accel in m/s^2 (any scale works, only directions and the ratio to
    // g are used), mag in any unit (nullptr: no magnetometer this step, e.g. Imu mode), all in
    // the sensor frame; dt_s the time since the previous step in seconds (0 < dt_s <= 0.1,
    // anything else, or under 1 us, only re-initialises the step and is not integrated).
    void update(Vec3f gyro_rad_s, Vec3f accel, const Vec3f* mag, float dt_s);

    bool initialised() const { return initialised_; }
    // Rotation sensor -> world (+Y up, -Z north in Ndof; -Z = initial forward without mag).
    Quatf orientation() const { return q_; }
    Vec3f gyro_bias_rad_s() const { return bias_; }
    // Whether the last update used the accelerometer / magnetometer correction.
    // Whether the last update() integrated a step (not an initialisation or a rejected dt).
    bool integrated() const { return integrated_; }
    bool accel_used() const { return accel_used_; }
    bool mag_used() const { return mag_used_; }

private:
    void initialise(Vec3f accel, const Vec3f* mag);
    bool mag_plausible(Vec3f mag, Vec3f up_sensor, float dt_s);

    MahonyGains gains_;
    MahonyLimits limits_;
    bool initialised_ = false;
    Quatf q_ = Quatf::identity();
    Vec3f bias_{};
    bool have_mag_reference_ = false;
    float mag_reference_norm_ = 0;
    float mag_reference_dip_sin_ = 0;  // sin of the dip: component along up / |m| (negative north)
    bool accel_used_ = false;
    bool mag_used_ = false;
    bool integrated_ = false;
    // Seconds since the field last corrected the heading (a sample stands for at most
    // kMaxMagGapS: after a disturbance the first plausible one is not weighted by the gap).
    static constexpr float kMaxMagGapS = 0.05f;
    float mag_gap_s_ = 0.0f;
};

}  // namespace glint::firmware
