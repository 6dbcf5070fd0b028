// The GPU accumulation (shaders/capture_accumulate.frag) against the CPU reference on the same
// frames: the issue asks for agreement within 1e-4 relative.
#include <gtest/gtest.h>

#include <cmath>

#include "appliance/capture/gpu_accumulator.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/sim/camera_simulator.hpp"
#include "appliance/sim/session_simulator.hpp"
#include "gpu_fixture.hpp"

namespace glint::capture {
namespace {

using sim::camera_look;
using sim::CameraSimulator;
using sim::SensorModel;

class GpuAccumulation : public test::GpuTest {};

TEST_F(GpuAccumulation, AgreesWithTheCpuReference) {
    const HdrImage env = load_exr(std::string(GLINT_BLENDER_WORLDS) + "/courtyard.exr").image;
    SensorModel sensor;
    CameraCalibration cal;
    cal.intrinsics = Intrinsics::from_fov(160, 90, 70 * kPi / 180);
    cal.intrinsics.k1 = -0.08;
    cal.intrinsics.k2 = 0.012;
    cal.intrinsics.p1 = 0.0007;
    cal.vignetting = {-0.22, 0.03, 0};
    cal.sensitivity = sensor.electrons_per_radiance_second / sensor.full_well_electrons;
    CameraSimulator sim(env, cal, sensor, {}, 3);
    const int w = 256, h = 128;
    // The GPU does not fill clipped reads from a bracket's shorter frames yet (docs/capture.md,
    // "Bracket fill"); these frames, 1 ns apart, would count as brackets wherever the exposure
    // fell.
    AccumulationSettings no_fill;
    no_fill.bracket_fill = false;
    HdrAccumulator cpu(w, h, no_fill);
    GpuAccumulator gpu(context(), w, h);
    int k = 0;
    for (double pitch : {-40.0, 0.0, 40.0, 80.0})
        for (double yaw = 0; yaw < 360; yaw += 40, ++k) {
            const glm::dquat q = camera_look(yaw + 7 * k, pitch, 3.0);
            const CameraFrame f = sim.render(q, k);
            cpu.add_frame(f, cal, q);
            gpu.add_frame(f, cal, q);
        }
    const HdrImage a = cpu.radiance(), b = gpu.radiance();
    {  // the GPU map merged on two threads is the one-thread merge, bit for bit
        const HdrImage b2 = gpu.radiance(2);
        int different = 0;
        for (int j = 0; j < h; ++j)
            for (int i = 0; i < w; ++i) {
                const Rgb x = b.at(i, j), y = b2.at(i, j);
                different += x.r != y.r || x.g != y.g || x.b != y.b;
            }
        EXPECT_EQ(different, 0);
    }
    const std::vector<std::uint32_t> sa = cpu.samples(), sb = gpu.samples();
    long long same = 0, compared = 0, count_differs = 0, above = 0;
    double worst = 0, sum_d2 = 0, sum_x2 = 0;
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) {
            const std::size_t t = std::size_t(j) * std::size_t(w) + std::size_t(i);
            if (sa[t] != sb[t]) {
                ++count_differs;  // a texel on a frustum edge, in on one side and out on the other
                continue;
            }
            ++same;
            if (sa[t] == 0) continue;
            const Rgb x = a.at(i, j), y = b.at(i, j);
            const double xs[3] = {x.r, x.g, x.b}, ys[3] = {y.r, y.g, y.b};
            for (int c = 0; c < 3; ++c) {
                if (xs[c] <= 0) continue;
                const double rel = std::abs(ys[c] - xs[c]) / xs[c];
                worst = std::max(worst, rel);
                above += rel > 1e-4 ? 1 : 0;
                sum_d2 += (ys[c] - xs[c]) * (ys[c] - xs[c]);
                sum_x2 += xs[c] * xs[c];
                ++compared;
            }
        }
    const double rms = std::sqrt(sum_d2 / sum_x2);
    std::printf("GPU vs CPU accumulation: %lld channel values compared, relative RMS %.2e, worst %.2e, %lld above "
                "1e-4; %lld of %d texels differ in sample count\n",
                compared, rms, worst, above, count_differs, w * h);
    EXPECT_GT(compared, 3 * w * h / 2);
    // Within 1e-4 relative: the map as a whole, and all but a few values at sharp edges, where
    // the float projection on the GPU moves a bilinear read by ~1e-4 pixel.
    EXPECT_LT(rms, 1e-4);
    EXPECT_LT(above, compared / 1000);
    EXPECT_LT(worst, 1e-3);
    EXPECT_LT(count_differs, w * h / 1000);  // frustum-edge texels only
    EXPECT_EQ(gpu.frames(), k);
}

}  // namespace
}  // namespace glint::capture
