// Golden images of `glint render`'s frames (docs/render.md, "Golden images"): a matte, a glossy
// (n = 160) and a mirror sphere over the studio world on a headless display, against the PNGs in
// images/golden/. The frames must agree within a tolerance that allows another llvmpipe build's
// rounding (another CPU, another Mesa) but not a change of what is drawn: at most 1 % of the
// pixels more than 8 codes off in a channel, and a mean difference under 1 code.
//
// GLINT_UPDATE_GOLDENS=1 writes the frames as the new goldens first (then look at them and
// commit them with the change that made them).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "appliance/convolution/convolution.hpp"
#include "appliance/gl/display.hpp"
#include "appliance/gl/png_writer.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "appliance/render/renderer.hpp"
#include "gpu_fixture.hpp"
#include "render_worlds.hpp"

namespace glint {
namespace {

namespace fs = std::filesystem;

gl::RgbImage render_frame(const HdrImage& world, const std::string& material) {
    const render::Material m = render::parse_material(material);
    convolution::Options o;
    o.tolerance = 0.01;
    const render::ShadingMaps maps = render::convolve_maps(world, m, o);
    gl::DisplayConfig config;
    config.kind = "headless";
    config.width = 320;
    config.height = 180;
    const auto display = gl::open_display(config);
    render::Renderer r(render::make_uv_sphere(), m, maps, display->width(), display->height());
    r.set_background_environment(world);
    r.meter();
    r.draw_scene();
    display->bind_frame();
    r.composite();
    gl::RgbImage frame = display->read_frame();
    display->present();
    return frame;
}

class RenderGolden : public test::GpuTest, public ::testing::WithParamInterface<const char*> {};

TEST_P(RenderGolden, FrameMatchesTheGoldenImage) {
    static const HdrImage world = test::small_blender_world("studio");
    const std::string material = GetParam();
    const std::string name = test::test_name(material);
    const fs::path golden = fs::path(GLINT_SOURCE_DIR) / "images" / "golden" / ("render_" + name + ".png");
    const gl::RgbImage frame = render_frame(world, material);
    context().make_current();  // the display's context is gone; the suite's goes on
    if (const char* update = std::getenv("GLINT_UPDATE_GOLDENS"); update && std::string(update) == "1") {
        // Written, then compared like any other run (so the update run also checks the frame is
        // not flat); look at the new goldens before committing them.
        fs::create_directories(golden.parent_path());
        gl::save_png(golden, frame);
        std::printf("[          ] wrote %s (GLINT_UPDATE_GOLDENS=1)\n", golden.c_str());
    }
    ASSERT_TRUE(fs::exists(golden)) << golden << " is missing: run with GLINT_UPDATE_GOLDENS=1 and commit it";
    const gl::RgbImage want = gl::load_png(golden);
    ASSERT_EQ(frame.width, want.width);
    ASSERT_EQ(frame.height, want.height);
    long long far = 0;
    double sum = 0;
    for (std::size_t i = 0; i < frame.pixels.size(); i += 3) {
        int worst = 0;
        for (std::size_t c = 0; c < 3; ++c) {
            const int d = std::abs(int(frame.pixels[i + c]) - int(want.pixels[i + c]));
            worst = std::max(worst, d);
            sum += d;
        }
        far += worst > 8;
    }
    const double pixels = double(frame.pixels.size() / 3);
    EXPECT_LE(double(far) / pixels, 0.01) << far << " pixels differ by more than 8 codes";
    EXPECT_LT(sum / double(frame.pixels.size()), 1.0);
    // The frame is not blank: the sphere and the studio differ (a black or uniform frame would
    // match a black golden written by a broken renderer only if the golden were broken too).
    int lo = 255, hi = 0;
    for (std::uint8_t v : frame.pixels) {
        lo = std::min(lo, int(v));
        hi = std::max(hi, int(v));
    }
    EXPECT_GT(hi - lo, 100);
}

INSTANTIATE_TEST_SUITE_P(Spheres, RenderGolden, ::testing::Values("matte", "glossy:160", "mirror"),
                         [](const ::testing::TestParamInfo<const char*>& p) { return test::test_name(p.param); });

}  // namespace
}  // namespace glint
