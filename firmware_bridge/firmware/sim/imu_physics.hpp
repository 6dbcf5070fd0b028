// What the simulated sensors measure: the true motion of a Trajectory turned into gyro, accel
// and magnetometer readings in the board's sensor frame, with configurable errors (white noise,
// a gyro bias that starts at a set value and drifts as a random walk, magnetic disturbances).
// Seeded: the same seed and the same read times give the same readings.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "firmware_bridge/firmware/sim/trajectory.hpp"

namespace glint::firmware::sim {

// An extra field (e.g. a steel door, a speaker magnet) in world coordinates between two times.
struct MagDisturbance {
    std::uint64_t start_us = 0;
    std::uint64_t end_us = 0;
    Vec3d field_world_ut;
};

struct SensorErrors {
    double gyro_noise_rad_s = 0.001;         // white noise, standard deviation per reading
    Vec3d gyro_bias_rad_s{0.01, -0.007, 0.004};  // bias at time 0, sensor frame
    double gyro_bias_walk_rad_s_per_sqrt_s = 0.0001;  // random-walk density of the bias drift
    double accel_noise_m_s2 = 0.02;          // white noise, standard deviation per reading
    double mag_noise_ut = 0.3;               // white noise, standard deviation per reading
    std::vector<MagDisturbance> mag_disturbances;

    static SensorErrors none();  // perfect sensors (for tests of conversions)
};

// Earth's field at the simulated site, world frame (+Y up, -Z north): 20 uT horizontal towards
// north, 44 uT vertical pointing down (dip about 66 deg, central Europe).
inline constexpr Vec3d kEarthFieldWorldUt{0.0, -44.0, -20.0};
inline constexpr double kGravity = 9.80665;  // m/s^2

struct SensorReadings {
    MotionState truth;
    Vec3d gyro_rad_s;   // sensor frame, with bias and noise
    Vec3d accel_m_s2;   // specific force, sensor frame (the board only rotates: gravity only)
    Vec3d mag_ut;       // sensor frame, with disturbance and noise
    Vec3d gyro_bias_rad_s;  // the true bias at this time
};

class ImuPhysics {
public:
    ImuPhysics(const Trajectory& trajectory, SensorErrors errors, std::uint64_t seed);

    // Readings at `time_us`. Times should not go backwards (the bias random walk advances with
    // time; an earlier time reuses the current bias).
    SensorReadings read(std::uint64_t time_us);
    MotionState truth(std::uint64_t time_us) const { return trajectory_.at(time_us); }
    const SensorErrors& errors() const { return errors_; }

private:
    double gauss(double sigma);

    const Trajectory& trajectory_;
    SensorErrors errors_;
    std::mt19937_64 rng_;
    std::normal_distribution<double> normal_{0.0, 1.0};
    Vec3d bias_;
    std::uint64_t bias_time_us_ = 0;
};

}  // namespace glint::firmware::sim
