// Trajectory files (format, errors naming file and line), built-ins, interpolation and the
// angular rate a gyro would measure.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>

#include "firmware_bridge/firmware/sim/sensor_sim.hpp"
#include "firmware_bridge/firmware/sim/trajectory.hpp"
#include "firmware_test_support.hpp"

namespace glint::firmware::sim {
namespace {

using test::kDeg;

std::string error_of(const std::string& text) {
    try {
        Trajectory::parse(text, "motion.csv");
    } catch (const std::runtime_error& e) {
        return e.what();
    }
    return "(no error)";
}

TEST(Trajectory, ParsesQuaternionAndYprFiles) {
    const Trajectory q = Trajectory::parse(
        "# turn 90 deg left in one second\nformat quaternion\n0, 1, 0, 0, 0\n1000000 0.70710678 0 0.70710678 0\n",
        "q.csv");
    ASSERT_EQ(q.samples().size(), 2u);
    EXPECT_EQ(q.end_us(), 1'000'000u);
    // Halfway: 45 deg about +Y, turning at 90 deg/s about the sensor's +Y.
    const MotionState mid = q.at(500'000);
    EXPECT_LT(test::angle_deg(mid.world_from_sensor, quat_from_ypr_deg(45, 0, 0)), 1e-6);
    EXPECT_NEAR(mid.angular_rate_rad_s.y, 90 * kDeg, 1e-9);
    EXPECT_NEAR(mid.angular_rate_rad_s.x, 0, 1e-9);

    const Trajectory ypr = Trajectory::parse("format ypr_deg\n0,0,0,0\n2000000, 0, 30, 0 # look up\n", "y.csv");
    EXPECT_LT(test::angle_deg(ypr.at(2'000'000).world_from_sensor,
                              Quatd::from_axis_angle({1, 0, 0}, 30 * kDeg)), 1e-9);
    // Held after the end unless looping.
    EXPECT_LT(test::angle_deg(ypr.at(9'000'000).world_from_sensor, ypr.at(2'000'000).world_from_sensor), 1e-9);
}

TEST(Trajectory, YawPitchRollFollowTheWorldFrame) {
    // Yaw +90: the sensor's -Z (forward) turns from north (-Z) to west (-X).
    const Vec3d fwd = quat_from_ypr_deg(90, 0, 0).rotate(Vec3d{0, 0, -1});
    EXPECT_NEAR(fwd.x, -1, 1e-12);
    // Pitch +30 raises the forward axis.
    EXPECT_GT(quat_from_ypr_deg(0, 30, 0).rotate(Vec3d{0, 0, -1}).y, 0.49);
}

TEST(Trajectory, ErrorsNameFileAndLine) {
    EXPECT_EQ(error_of(""), "motion.csv:0: no samples: the file is empty");
    EXPECT_EQ(error_of("0,1,0,0\n"),
              "motion.csv:1: expected samples t_seconds,w,x,y,z (or a line 'format quaternion' / 'format ypr_deg')");
    EXPECT_EQ(error_of("0,1,0,0,0\n0.5,1,0,0\n"), "motion.csv:2: expected 5 fields (t_seconds, w, x, y, z), got 4");
    EXPECT_EQ(error_of("0.1,1,0,0,0\n"), "motion.csv:1: the first sample must be at time 0");
    EXPECT_EQ(error_of("format quaternion\n0,1,0,0,0\n5,1,0,0\n"),
              "motion.csv:3: expected 5 fields (time_us, w, x, y, z), got 4");
    EXPECT_EQ(error_of("format quaternion\n\n0,1,0,0,0\n10,1,0,zero,0\n"),
              "motion.csv:4: field 4 'zero' is not a finite number");
    EXPECT_EQ(error_of("format quaternion\n0,1,0,0,0\n10,2,0,0,0\n"),
              "motion.csv:3: quaternion norm 2.000000 is not 1 (+-0.01)");
    EXPECT_EQ(error_of("format ypr_deg\n0,0,0,0\n10,0,0,0\n10,1,0,0\n"),
              "motion.csv:4: time_us 10 does not increase (previous 10 us)");
    // In the file's own unit (it said "time_us 0.5 ... (previous 900000)" of a seconds file).
    EXPECT_EQ(error_of("0,1,0,0,0\n0.9,1,0,0,0\n0.5,1,0,0,0\n"),
              "motion.csv:3: t_seconds 0.5 does not increase (previous 0.900000 s)");
    EXPECT_EQ(error_of("format ypr_deg\n5,0,0,0\n"), "motion.csv:2: the first sample must be at time 0");
    EXPECT_EQ(error_of("format ypr_deg\n-1,0,0,0\n"),
              "motion.csv:2: time_us '-1' is not a whole number of microseconds >= 0");
    EXPECT_EQ(error_of("format ypr_deg\n0,nan,0,0\n"), "motion.csv:2: field 2 'nan' is not a finite number");
    EXPECT_EQ(error_of("format ypr_deg\n# nothing\n"), "motion.csv:2: no samples after the format line");
}

TEST(Trajectory, ReadsTheSecondsFormatWithoutAFormatLine) {
    // The fixed format (firmware/README.md, "Trajectory files"): t_seconds,w,x,y,z, camera/sensor to world.
    const Trajectory t = Trajectory::parse("# a quarter turn\n0,1,0,0,0\n2.5,0.70710678,0,0.70710678,0\n", "m.csv");
    ASSERT_EQ(t.samples().size(), 2u);
    EXPECT_EQ(t.samples()[1].time_us, 2'500'000u);
    const Quatd mid = t.at(1'250'000).world_from_sensor;
    EXPECT_NEAR(angle_between(mid, Quatd::from_axis_angle({0, 1, 0}, 3.14159265358979 / 4)), 0.0, 1e-6);
}

TEST(Trajectory, LoadNamesAMissingFileAndReadsARealOne) {
    EXPECT_THROW(Trajectory::load("/nonexistent/dir/motion.csv"), std::runtime_error);
    try {
        load_trajectory("/nonexistent/dir/motion.csv");
        ADD_FAILURE() << "a missing trajectory file was loaded without an error";
    } catch (const std::runtime_error& e) {
        EXPECT_EQ(std::string(e.what()), "/nonexistent/dir/motion.csv: cannot open trajectory file");
    }
    const std::string path = testing::TempDir() + "glint_traj_truncated.csv";
    {
        std::ofstream out(path);
        out << "format quaternion\n0,1,0,0,0\n1000,1,0";  // truncated mid-line
    }
    try {
        load_trajectory(path);
        ADD_FAILURE() << "a truncated file was accepted";
    } catch (const std::runtime_error& e) {
        EXPECT_EQ(std::string(e.what()), path + ":3: expected 5 fields (time_us, w, x, y, z), got 3");
    }
    std::remove(path.c_str());
}

TEST(Trajectory, BuiltinsLoopAndUnknownNamesAreListed) {
    for (const std::string& name : Trajectory::builtin_names()) {
        const Trajectory t = load_trajectory("builtin:" + name);
        EXPECT_TRUE(t.loops()) << name;
        EXPECT_LT(test::angle_deg(t.at(t.end_us() + 1234).world_from_sensor, t.at(1234).world_from_sensor), 1e-6)
            << name;
    }
    try {
        load_trajectory("builtin:spin");
        ADD_FAILURE();
    } catch (const std::runtime_error& e) {
        EXPECT_EQ(std::string(e.what()), "unknown built-in trajectory 'spin' (known: static, yaw-sweep, tumble, kiosk)");
    }
}

TEST(Trajectory, AngularRateIntegratesToTheMotion) {
    // Integrating the reported body rate reproduces the trajectory (checks frame and sign).
    const Trajectory t = Trajectory::builtin("tumble");
    Quatd q = t.at(0).world_from_sensor;
    const std::uint64_t step = 1000;
    for (std::uint64_t us = 0; us < 10'000'000; us += step) {
        const Vec3d w = t.at(us + step / 2).angular_rate_rad_s;
        const double rate = norm(w);
        if (rate > 0) q = normalized(q * Quatd::from_axis_angle((1 / rate) * w, rate * step * 1e-6));
    }
    EXPECT_LT(test::angle_deg(q, t.at(10'000'000).world_from_sensor), 0.05);
}


// At a sample's own time the rate is the segment's that ends there (a gyro's reading averages the
// moments before it): a board sampling on the grid integrates each reading over the interval
// before it, which must be the interval the reading describes.
TEST(Trajectory, RateAtASampleIsTheSegmentEndingThere) {
    const Trajectory t = Trajectory::parse("format ypr_deg\n0,0,0,0\n1000000,10,0,0\n2000000,40,0,0\n", "r.csv");
    EXPECT_NEAR(t.at(0).angular_rate_rad_s.y, 10 * kDeg, 1e-9);          // the first segment
    EXPECT_NEAR(t.at(500'000).angular_rate_rad_s.y, 10 * kDeg, 1e-9);
    EXPECT_NEAR(t.at(1'000'000).angular_rate_rad_s.y, 10 * kDeg, 1e-9);  // the segment ending there
    EXPECT_NEAR(t.at(1'000'001).angular_rate_rad_s.y, 30 * kDeg, 1e-6);
    EXPECT_NEAR(t.at(2'000'000).angular_rate_rad_s.y, 0, 1e-9);          // held after the end
}

}  // namespace
}  // namespace glint::firmware::sim
