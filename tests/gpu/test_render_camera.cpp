// The renderer into the camera's image space (docs/render.md, "Camera response"): a grey patch of
// known radiance renders to the 8-bit code the capture pipeline's camera model gives it
// (capture::Response, the simulator's forward curve), a tabulated response likewise, and a
// background image's codes are decoded with the inverse response where the object's antialiased
// edge mixes with them.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "appliance/capture/calibration_io.hpp"
#include "appliance/capture/camera_model.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/gl/gl_objects.hpp"
#include "appliance/render/camera_response.hpp"
#include "appliance/render/maps.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "appliance/render/renderer.hpp"
#include "gpu_fixture.hpp"

namespace glint {
namespace {

namespace fs = std::filesystem;

class RenderCamera : public test::GpuTest {
protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() / ("glint_test_render_camera_" + std::to_string(::getpid()));
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }
    fs::path dir_;
};

constexpr int kW = 48, kH = 32;

// Constant irradiance 1: a matte object of albedo kd has radiance kd everywhere.
render::ShadingMaps uniform_maps() {
    render::ShadingMaps maps;
    HdrImage e(16, 8);
    for (auto& v : e.data()) v = 1.0f;
    maps.irradiance = e;
    return maps;
}

// The composite into an RGBA8 target, read back (bottom row first), RGB per pixel.
std::vector<std::uint8_t> composite_8bit(const render::Renderer& r) {
    gl::GlTexture colour = gl::GlTexture::create();
    glBindTexture(GL_TEXTURE_2D, colour.id());
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, kW, kH, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
    gl::GlFramebuffer fb = gl::GlFramebuffer::create();
    glBindFramebuffer(GL_FRAMEBUFFER, fb.id());
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, colour.id(), 0);
    const GLenum buffer = GL_COLOR_ATTACHMENT0;
    glDrawBuffers(1, &buffer);
    glViewport(0, 0, kW, kH);
    r.composite();
    std::vector<std::uint8_t> rgba(std::size_t(kW) * kH * 4);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glReadPixels(0, 0, kW, kH, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    return rgba;
}

fs::path write_calibration(const fs::path& dir, bool tabulated, bool noise = false) {
    capture::CameraCalibration cal;
    if (noise) {  // the simulator's sensor
        cal.noise_full_well_electrons = 6000;
        cal.noise_read = 0.002;
    }
    cal.intrinsics = capture::Intrinsics::from_fov(320, 180, 1.2);
    cal.response = capture::Response::parametric(2.2, 0.25);
    if (tabulated) cal.response.gamma = cal.response.shoulder = 0;  // only the table
    cal.sensitivity = 100;  // the simulator's 6e5 electrons per radiance-second over a 6000 full well
    const fs::path path = dir / (tabulated ? "table.json" : noise ? "noise.json" : "calibration.json");
    capture::save_calibration(path, cal);
    return path;
}

TEST_F(RenderCamera, GreyPatchRendersToTheCameraModelsCode) {
    const render::CameraResponse response = render::load_camera_response(write_calibration(dir_, false));
    EXPECT_TRUE(response.parametric());
    const capture::Response model = capture::Response::parametric(2.2, 0.25);
    const render::CameraExposure exposure{20.0, 2.0};  // 20 ms at gain 2: X = radiance x 4
    for (const double radiance : {0.004, 0.03, 0.09, 0.18, 0.27}) {
        render::Material grey = render::parse_material("matte");
        grey.kd = glm::dvec3(radiance);
        render::Renderer r(render::make_uv_sphere(16, 32), grey, uniform_maps(), kW, kH);
        r.set_background_black();
        r.set_camera_response(response, exposure);
        r.draw_scene();
        const double x = radiance * 0.020 * 2.0 * 100;
        const int want = int(std::lround(model.forward(x)));  // the simulator's quantisation
        const std::vector<std::uint8_t> frame = composite_8bit(r);
        const std::uint8_t* centre = &frame[4 * std::size_t((kH / 2) * kW + kW / 2)];
        EXPECT_EQ(int(centre[0]), want) << "radiance " << radiance << " (X " << x << ", forward " << model.forward(x) << ")";
        EXPECT_EQ(int(centre[1]), want);
        EXPECT_EQ(int(centre[2]), want);
        EXPECT_NEAR(response.code(x), model.forward(x), 1e-9);
        EXPECT_EQ(int(frame[0]), 0);  // the black background stays black
    }
}

TEST_F(RenderCamera, TabulatedResponseAndImageDecodedThroughItsInverse) {
    const render::CameraResponse table = render::load_camera_response(write_calibration(dir_, true));
    EXPECT_FALSE(table.parametric());
    const capture::Response model = capture::Response::parametric(2.2, 0.25);
    // At the table's points the piecewise-linear inverse is the curve itself.
    for (int z : {1, 17, 100, 200, 254}) EXPECT_NEAR(table.code(table.inverse[std::size_t(z)]), double(z), 1e-9);
    EXPECT_NEAR(table.code(0.3), model.forward(0.3), 0.05);

    // A grey image of code 90 behind the sphere, 4x MSAA: at the silhouette the frame's code is
    // the response of the coverage-weighted mix of the object's exposure and inverse[90].
    gl::RgbImage image;
    image.width = 8;
    image.height = 8;
    image.pixels.assign(8 * 8 * 3, 90);
    render::Material grey = render::parse_material("matte");
    grey.kd = glm::dvec3(0.12);
    const render::CameraExposure exposure{10.0, 1.0};  // X = radiance x 1
    render::Renderer r(render::make_uv_sphere(16, 32), grey, uniform_maps(), kW, kH, render::Camera{}, 4);
    r.set_background_image(image);
    r.set_camera_response(table, exposure);
    r.draw_scene();
    const std::vector<float> radiance = r.read_frame_radiance();  // top row first
    const std::vector<std::uint8_t> frame = composite_8bit(r);     // bottom row first
    int partial = 0, background = 0, worst = 0;
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) {
            const std::size_t k = std::size_t(y * kW + x);
            const float a = radiance[4 * k + 3];
            const int got = frame[4 * std::size_t((kH - 1 - y) * kW + x)];
            double want = 90;
            if (a > 0) {
                want = std::round(table.code(0.12 * a + (1 - a) * table.inverse[90]));
                if (a < 1) ++partial;
            } else {
                ++background;
            }
            worst = std::max(worst, std::abs(got - int(want)));
        }
    EXPECT_GT(partial, 10);
    EXPECT_GT(background, 100);
    EXPECT_LE(worst, 1);  // float arithmetic on the GPU against double here
}

// The sensor's noise on virtual pixels: a grey object of exposure X renders with the spread of
// codes the model gives (variance of X: X gain / full well + read^2, through the curve's slope),
// centred on forward(X); a new pattern each frame, the same for the same frame; the black
// background (the video's, not virtual) untouched.
TEST_F(RenderCamera, MatchedNoiseHasTheSensorModelsSpread) {
    const fs::path cal = write_calibration(dir_, false, true);
    const render::CameraResponse response = render::load_camera_response(cal);
    ASSERT_TRUE(response.has_noise());
    EXPECT_EQ(response.full_well_electrons, 6000);
    EXPECT_EQ(response.read_noise, 0.002);
    EXPECT_EQ(capture::load_calibration(cal).noise_full_well_electrons, 6000);  // capture's reader too
    const capture::Response model = capture::Response::parametric(2.2, 0.25);
    const render::CameraExposure exposure{20.0, 2.0};  // X = radiance x 4
    render::Material grey = render::parse_material("matte");
    grey.kd = glm::dvec3(0.0125);  // X = 0.05
    render::Renderer r(render::make_uv_sphere(16, 32), grey, uniform_maps(), kW, kH);
    r.set_background_black();
    r.set_camera_response(response, exposure);
    r.draw_scene();
    const double x = 0.05;
    const double sigma_x = std::sqrt(x * 2.0 / 6000 + 0.002 * 0.002);
    const double slope = (model.forward(x + 1e-4) - model.forward(x - 1e-4)) / 2e-4;
    // Rounding to codes adds 1/12 code^2.
    const double want_sigma = std::sqrt(slope * slope * sigma_x * sigma_x + 1.0 / 12.0);
    const auto central = [&](const std::vector<std::uint8_t>& frame) {
        std::vector<int> codes;
        for (int y = kH / 2 - 5; y < kH / 2 + 5; ++y)
            for (int xx = kW / 2 - 6; xx < kW / 2 + 6; ++xx)
                for (int c = 0; c < 3; ++c) codes.push_back(frame[4 * std::size_t(y * kW + xx) + std::size_t(c)]);
        return codes;
    };
    const std::vector<std::uint8_t> clean = composite_8bit(r);
    for (int code : central(clean)) ASSERT_EQ(code, int(std::lround(model.forward(x))));
    r.set_camera_match({true, 1, {0, 0}});
    const std::vector<std::uint8_t> noisy = composite_8bit(r);
    const std::vector<int> codes = central(noisy);
    double mean = 0, var = 0;
    for (int c : codes) mean += c;
    mean /= double(codes.size());
    for (int c : codes) var += (c - mean) * (c - mean);
    const double sigma = std::sqrt(var / double(codes.size() - 1));
    std::printf("matched noise: %.3f codes measured, %.3f predicted, mean %.2f against %.2f\n", sigma, want_sigma, mean, model.forward(x));
    EXPECT_GT(want_sigma, 2.0);  // a spread the test can see
    EXPECT_NEAR(sigma, want_sigma, 0.15 * want_sigma) << "slope " << slope << " codes per unit X";
    EXPECT_NEAR(mean, model.forward(x), 0.5);
    EXPECT_EQ(int(noisy[0]), 0);  // the background is the video's: no noise added
    EXPECT_EQ(composite_8bit(r), noisy);  // the same frame, the same pattern
    r.set_camera_match({true, 2, {0, 0}});
    EXPECT_NE(composite_8bit(r), noisy);
}

TEST_F(RenderCamera, MatchingNeedsTheNoiseModelAndBoundedBlur) {
    render::Renderer r(render::make_uv_sphere(8, 16), render::parse_material("matte"), uniform_maps(), kW, kH);
    EXPECT_THROW(r.set_camera_match({true, 0, {0, 0}}), InputError);  // no response yet
    r.set_camera_response(render::load_camera_response(write_calibration(dir_, false)), {10.0, 1.0});
    try {
        r.set_camera_match({true, 0, {0, 0}});
        FAIL() << "noise without a noise model";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("has no \"noise\""), std::string::npos) << e.what();
    }
    EXPECT_THROW(r.set_camera_match({false, 0, {300, 0}}), InputError);
    EXPECT_THROW(r.set_camera_match({false, 0, {NAN, 0}}), InputError);
    EXPECT_NO_THROW(r.set_camera_match({false, 0, {20, -5}}));
}

// The object's motion blur: a horizontal motion of 16 pixels during the exposure widens the
// object by 16 pixels across and not at all up and down, and keeps its light (a box filter of the
// smear): the decoded exposure summed over the frame stays within 3 %.
TEST_F(RenderCamera, MotionBlurSmearsTheObjectAlongItsPathAndKeepsItsLight) {
    const render::CameraResponse response = render::load_camera_response(write_calibration(dir_, false));
    render::Material grey = render::parse_material("matte");
    grey.kd = glm::dvec3(0.1);
    render::Renderer r(render::make_uv_sphere(16, 32), grey, uniform_maps(), kW, kH, render::Camera{}, 4);
    r.set_background_black();
    r.set_camera_response(response, {10.0, 1.0});
    r.draw_scene();
    const auto measure = [&](const std::vector<std::uint8_t>& frame, int& width, int& height, double& light) {
        int x0 = kW, x1 = -1, y0 = kH, y1 = -1;
        light = 0;
        for (int y = 0; y < kH; ++y)
            for (int x = 0; x < kW; ++x) {
                const int z = frame[4 * std::size_t(y * kW + x)];
                if (z == 0) continue;
                light += response.inverse[std::size_t(z)];
                if (y == kH / 2) x0 = std::min(x0, x), x1 = std::max(x1, x);
                if (x == kW / 2) y0 = std::min(y0, y), y1 = std::max(y1, y);
            }
        width = x1 - x0 + 1;
        height = y1 - y0 + 1;
    };
    int w0 = 0, h0 = 0, w1 = 0, h1 = 0;
    double light0 = 0, light1 = 0;
    measure(composite_8bit(r), w0, h0, light0);
    r.set_camera_match({false, 0, {16, 0}});
    measure(composite_8bit(r), w1, h1, light1);
    EXPECT_LT(w0 + 16, kW);  // the smear fits in the frame
    EXPECT_NEAR(w1, w0 + 16, 2);
    EXPECT_EQ(h1, h0);
    EXPECT_NEAR(light1, light0, 0.03 * light0);
}

TEST_F(RenderCamera, BadCalibrationsAreNamedWithTheKey) {
    const fs::path good = write_calibration(dir_, false);
    std::string text;
    {
        std::ifstream in(good);
        text.assign(std::istreambuf_iterator<char>(in), {});
    }
    std::string bad = text;
    bad.replace(bad.find("\"sensitivity\""), 13, "\"sensitivityX\"");
    std::ofstream(dir_ / "bad.json") << bad;
    try {
        render::load_camera_response(dir_ / "bad.json");
        FAIL() << "no sensitivity accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("sensitivity"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("--camera"), std::string::npos) << e.what();
    }
    EXPECT_THROW(render::load_camera_response(dir_ / "missing.json"), InputError);
}

}  // namespace
}  // namespace glint
