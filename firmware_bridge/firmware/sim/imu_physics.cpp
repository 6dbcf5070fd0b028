// Simulated sensor readings: see imu_physics.hpp.
#include "firmware_bridge/firmware/sim/imu_physics.hpp"

#include <cmath>

namespace glint::firmware::sim {

SensorErrors SensorErrors::none() {
    SensorErrors e;
    e.gyro_noise_rad_s = 0;
    e.gyro_bias_rad_s = {};
    e.gyro_bias_walk_rad_s_per_sqrt_s = 0;
    e.accel_noise_m_s2 = 0;
    e.mag_noise_ut = 0;
    return e;
}

ImuPhysics::ImuPhysics(const Trajectory& trajectory, SensorErrors errors, std::uint64_t seed)
    : trajectory_(trajectory), errors_(std::move(errors)), rng_(seed), bias_(errors_.gyro_bias_rad_s) {}

double ImuPhysics::gauss(double sigma) { return sigma == 0.0 ? 0.0 : sigma * normal_(rng_); }

SensorReadings ImuPhysics::read(std::uint64_t time_us) {
    if (time_us > bias_time_us_) {
        // Random walk: the bias moves by N(0, density^2 * dt) per axis over dt.
        const double dt_s = static_cast<double>(time_us - bias_time_us_) * 1e-6;
        const double step = errors_.gyro_bias_walk_rad_s_per_sqrt_s * std::sqrt(dt_s);
        bias_ += Vec3d{gauss(step), gauss(step), gauss(step)};
        bias_time_us_ = time_us;
    }
    SensorReadings r;
    r.truth = trajectory_.at(time_us);
    const Quatd& q = r.truth.world_from_sensor;
    const double gn = errors_.gyro_noise_rad_s;
    r.gyro_rad_s = r.truth.angular_rate_rad_s + bias_ + Vec3d{gauss(gn), gauss(gn), gauss(gn)};
    r.gyro_bias_rad_s = bias_;
    const double an = errors_.accel_noise_m_s2;
    r.accel_m_s2 = q.rotate_inverse(Vec3d{0, kGravity, 0}) + Vec3d{gauss(an), gauss(an), gauss(an)};
    Vec3d field = kEarthFieldWorldUt;
    for (const MagDisturbance& d : errors_.mag_disturbances) {
        if (time_us >= d.start_us && time_us < d.end_us) field += d.field_world_ut;
    }
    const double mn = errors_.mag_noise_ut;
    r.mag_ut = q.rotate_inverse(field) + Vec3d{gauss(mn), gauss(mn), gauss(mn)};
    return r;
}

}  // namespace glint::firmware::sim
