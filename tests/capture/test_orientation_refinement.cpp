#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "appliance/capture/drift_correction.hpp"
#include "appliance/capture/orientation_refinement.hpp"
#include "appliance/core/equirect.hpp"

namespace glint::capture {
namespace {

constexpr double kDeg = kPi / 180.0;

// A scan: the true camera turns about +Y and tilts; the sensor drifts 1 deg/min about +Y and
// has a little white noise; the images are consistent but the sphere as a whole sits 0.4 degrees
// off (what frame-to-mosaic alignment inherits from its first frames).
struct Scan {
    std::vector<RefinedFrame> frames;
    std::vector<Quatd> truth;
};

Scan make_scan(double untrusted_after_s) {
    Scan s;
    std::mt19937 rng(7);
    std::normal_distribution<double> noise(0.0, 0.05 * kDeg);
    const Quatd sphere_offset = rotation_from_vector({0.1 * kDeg, 0.4 * kDeg, -0.1 * kDeg});
    for (int k = 0; k < 180; ++k) {
        const double t = k / 3.0;
        const Quatd truth = firmware::normalized(Quatd::from_axis_angle({0, 1, 0}, 0.6 * t) *
                                                 Quatd::from_axis_angle({1, 0, 0}, 0.3 * std::sin(0.1 * t)));
        const Quatd drift = rotation_from_vector({noise(rng), -t / 60.0 * kDeg + noise(rng), noise(rng)});
        RefinedFrame f;
        f.t_s = t;
        f.sensor = firmware::normalized(drift * truth);
        f.image = firmware::normalized(sphere_offset * truth);
        f.trusted = t < untrusted_after_s || k % 3 == 0;  // after it, a frame in three aligns
        s.frames.push_back(f);
        s.truth.push_back(truth);
    }
    return s;
}

TEST(OrientationRefinement, TheDriftLineTiesConsistentImagesBackToTheSensorsFrame) {
    const Scan s = make_scan(1e9);
    DriftLine line;
    const std::vector<Quatd> q = anchor_to_sensor(s.frames, &line);
    ASSERT_EQ(q.size(), s.frames.size());
    EXPECT_EQ(line.frames, 180);
    // The sensor drifts -1 deg/min about +Y; the offset a is the sphere's 0.4 degrees.
    EXPECT_NEAR(line.rate_rad_per_s.y * 60 / kDeg, 1.0, 0.02);  // r = log(image sensor^-1) grows by +1 deg/min
    EXPECT_NEAR(line.offset_rad.y / kDeg, 0.4, 0.02);
    double worst = 0;
    for (std::size_t i = 0; i < q.size(); ++i) worst = std::max(worst, firmware::angle_between(q[i], s.truth[i]) / kDeg);
    EXPECT_LT(worst, 0.03);  // without the fit: 0.42 degrees (the sphere's own offset)
}

TEST(OrientationRefinement, UntrustedFramesTakeANeighboursCorrectionOrTheLine) {
    Scan s = make_scan(40);
    // Frames after 55 s have no trusted neighbour within a second: the line carries them.
    for (RefinedFrame& f : s.frames)
        if (f.t_s > 55) f.trusted = false;
    const std::vector<Quatd> q = anchor_to_sensor(s.frames, nullptr);
    double worst_neighbour = 0, worst_line = 0;
    for (std::size_t i = 0; i < q.size(); ++i) {
        if (s.frames[i].trusted) continue;
        const double e = firmware::angle_between(q[i], s.truth[i]) / kDeg;
        (s.frames[i].t_s > 56 ? worst_line : worst_neighbour) = std::max(s.frames[i].t_s > 56 ? worst_line : worst_neighbour, e);
    }
    EXPECT_LT(worst_neighbour, 0.3);  // the neighbour's correction, off by the sensor noise
    EXPECT_LT(worst_line, 0.3);       // the sensor with the line's drift removed; uncorrected ~1 degree
    EXPECT_GT(worst_line, 0.0);
}

TEST(OrientationRefinement, TooFewTrustedFramesLeaveTheOrientationsAsGiven) {
    Scan s = make_scan(0);
    for (std::size_t i = 0; i < s.frames.size(); ++i) s.frames[i].trusted = i < 5;
    DriftLine line;
    const std::vector<Quatd> q = anchor_to_sensor(s.frames, &line);
    EXPECT_EQ(line.frames, 0);
    EXPECT_LT(firmware::angle_between(q[0], s.frames[0].image), 1e-12);
    EXPECT_LT(firmware::angle_between(q[10], s.frames[10].sensor), 1e-12);
}

}  // namespace
}  // namespace glint::capture
