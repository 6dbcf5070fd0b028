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

fs::path write_calibration(const fs::path& dir, bool tabulated) {
    capture::CameraCalibration cal;
    cal.intrinsics = capture::Intrinsics::from_fov(320, 180, 1.2);
    cal.response = capture::Response::parametric(2.2, 0.25);
    if (tabulated) cal.response.gamma = cal.response.shoulder = 0;  // only the table
    cal.sensitivity = 100;  // the simulator's 6e5 electrons per radiance-second over a 6000 full well
    const fs::path path = dir / (tabulated ? "table.json" : "calibration.json");
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
