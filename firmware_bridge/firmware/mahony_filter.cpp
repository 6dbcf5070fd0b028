// Mahony explicit complementary filter: see mahony_filter.hpp for the equations and source.
#include "firmware_bridge/firmware/mahony_filter.hpp"

#include <cmath>

namespace glint::firmware {
namespace {

constexpr Vec3f kWorldUp{0.0f, 1.0f, 0.0f};
constexpr Vec3f kWorldNorth{0.0f, 0.0f, -1.0f};

Vec3f normalized_or_zero(Vec3f v) {
    const float n = norm(v);
    return n > 1e-12f ? (1.0f / n) * v : Vec3f{};
}

float clamp(float v, float limit) { return v > limit ? limit : (v < -limit ? -limit : v); }

// Rotation sensor -> world whose rows are the world axes written in sensor coordinates.
Quatf from_sensor_basis(Vec3f east, Vec3f up, Vec3f north) {
    const float m[3][3] = {{east.x, east.y, east.z}, {up.x, up.y, up.z}, {-north.x, -north.y, -north.z}};
    return quat_from_matrix(m);
}

}  // namespace

void MahonyFilter::reset() {
    initialised_ = false;
    q_ = Quatf::identity();
    bias_ = {};
    have_mag_reference_ = false;
    mag_gap_s_ = 0.0f;
    accel_used_ = mag_used_ = false;
}

void MahonyFilter::set_orientation(Quatf world_from_sensor) {
    q_ = normalized(world_from_sensor);
    initialised_ = true;
}

// TRIAD from one sample: up is the accelerometer direction; north is the horizontal part of the
// field (Ndof) or of the sensor's -Z axis (Imu: "world -Z is where the sensor's -Z pointed").
void MahonyFilter::initialise(Vec3f accel, const Vec3f* mag) {
    const Vec3f up = normalized_or_zero(accel);
    if (norm(up) == 0.0f) return;
    Vec3f horizontal{};
    if (mag != nullptr) {
        // east = m x up (the downward part of m drops out), north = up x east.
        horizontal = normalized_or_zero(cross(up, normalized_or_zero(cross(*mag, up))));
    }
    if (norm(horizontal) == 0.0f) {
        const Vec3f candidates[] = {{0, 0, -1}, {0, 1, 0}, {1, 0, 0}};
        for (Vec3f axis : candidates) {
            horizontal = normalized_or_zero(axis - dot(axis, up) * up);
            if (norm(horizontal) > 0.5f) break;  // sensor axis not (almost) vertical
        }
    }
    const Vec3f north = horizontal;
    const Vec3f east = cross(north, up);
    q_ = from_sensor_basis(east, up, north);
    initialised_ = true;
}

bool MahonyFilter::mag_plausible(Vec3f mag, Vec3f up_sensor, float dt_s) {
    const float n = norm(mag);
    if (!(n > 0.0f)) return false;
    const float dip_sin = dot(mag, up_sensor) / n;
    if (!have_mag_reference_) {
        mag_reference_norm_ = n;
        mag_reference_dip_sin_ = dip_sin;
        have_mag_reference_ = true;
        return true;
    }
    const float norm_change = std::fabs(n - mag_reference_norm_) / mag_reference_norm_;
    const float dip_change = std::fabs(std::asin(clamp(dip_sin, 1.0f)) -
                                       std::asin(clamp(mag_reference_dip_sin_, 1.0f)));
    if (norm_change > limits_.mag_norm_tolerance || dip_change > limits_.mag_dip_tolerance_rad) {
        return false;
    }
    // Follow slow changes (temperature, moving to another room) but not disturbances.
    const float a = dt_s / (limits_.mag_reference_time_s + dt_s);
    mag_reference_norm_ += a * (n - mag_reference_norm_);
    mag_reference_dip_sin_ += a * (dip_sin - mag_reference_dip_sin_);
    return true;
}

void MahonyFilter::update(Vec3f gyro_rad_s, Vec3f accel, const Vec3f* mag, float dt_s) {
    accel_used_ = mag_used_ = integrated_ = false;
    if (!initialised_) {
        initialise(accel, mag);
        return;
    }
    if (!(dt_s >= 1e-6f) || dt_s > 0.1f) return;  // the field's weight gap / dt stays finite
    integrated_ = true;
    // Time since the field last corrected the heading, up to kMaxMagGapS (see below).
    mag_gap_s_ = std::fmin(mag_gap_s_ + dt_s, kMaxMagGapS);

    // The measurements are of this sample's time; the estimate is of the previous sample's. The
    // error is taken against the estimate carried to now by the gyro: taken against the
    // previous estimate, the feedback settles where that estimate matches the measurement, one
    // sample early (5 ms at 200 Hz in steady motion; measured 2026-12-08).
    const Vec3f rate = gyro_rad_s - bias_;
    Quatf predicted = q_;
    const float rate_norm = norm(rate);
    if (rate_norm > 0.0f) predicted = normalized(q_ * Quatf::from_axis_angle((1.0f / rate_norm) * rate, rate_norm * dt_s));

    // The correction as applied (error: the heading's term weighted by the time its sample
    // stands for) and as measured (error_measured: the bias's anti-windup test).
    Vec3f error{};
    const Vec3f up_sensor = predicted.rotate_inverse(kWorldUp);  // predicted direction of +g reaction
    const float accel_norm = norm(accel);
    if (std::fabs(accel_norm - limits_.gravity_m_s2) <=
        limits_.accel_tolerance * limits_.gravity_m_s2) {
        error += cross((1.0f / accel_norm) * accel, up_sensor);
        accel_used_ = true;
    }
    Vec3f error_measured = error;
    if (mag != nullptr && mag_plausible(*mag, normalized_or_zero(accel), mag_gap_s_)) {
        const Vec3f field_world = predicted.rotate(*mag);
        const Vec3f horizontal = normalized_or_zero(Vec3f{field_world.x, 0.0f, field_world.z});
        if (norm(horizontal) > 0.0f) {
            const Vec3f heading_error_world = cross(horizontal, kWorldNorth);  // along +-up
            const Vec3f heading_error = gains_.mag_weight * predicted.rotate_inverse(heading_error_world);
            // A field sample is passed once, when the chip has a new one (its rate may be below
            // the gyro's): it corrects for the time since the last one, so that the heading's
            // time constant does not depend on the magnetometer's rate; kp gap e at most half the
            // error, or after a long gap (a disturbance, a restart) a large kp overshoots.
            const float gain = gains_.kp * gains_.mag_weight;
            const float gap = gain > 0.0f ? std::fmin(mag_gap_s_, 0.5f / gain) : mag_gap_s_;
            error += (std::fmax(gap, dt_s) / dt_s) * heading_error;
            error_measured += heading_error;
            mag_gap_s_ = 0.0f;
            mag_used_ = true;
        }
    }

    // Integral feedback: the bias estimate moves against the error (db/dt = -kI e).
    if (norm(error_measured) < limits_.bias_error_limit) bias_ -= (gains_.ki * dt_s) * error;
    bias_ = {clamp(bias_.x, limits_.max_bias_rad_s), clamp(bias_.y, limits_.max_bias_rad_s),
             clamp(bias_.z, limits_.max_bias_rad_s)};
    const Vec3f omega = gyro_rad_s - bias_ + gains_.kp * error;

    // Exact integration of a constant rate over dt: q <- q (x) exp(omega dt / 2).
    const float omega_norm = norm(omega);
    if (omega_norm > 0.0f) {
        q_ = normalized(q_ * Quatf::from_axis_angle((1.0f / omega_norm) * omega, omega_norm * dt_s));
    }
}

}  // namespace glint::firmware
