// The visitor screens at other display sizes (a 7" 800x480 panel, a 1024x600 panel, 1080p): the
// layout scales with the height, so each screen still shows its text inside the frame, the
// progress bar still fills as far as the progress, and the AR screen's centre stays clear.
#include <gtest/gtest.h>

#include <GLES3/gl3.h>

#include "appliance/gl/gl_objects.hpp"
#include "appliance/ui/screens.hpp"
#include "tests/ui/ui_fixture.hpp"

using namespace glint;
using namespace glint::test;
using glint::ui::KioskState;

namespace {

// An offscreen RGBA8 frame of its own size in the fixture's context, filled with a flat grey.
class Offscreen {
public:
    Offscreen(int width, int height) : width_(width), height_(height) {
        glBindTexture(GL_TEXTURE_2D, colour_.id());
        glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, width, height, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
        glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
        glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, colour_.id(), 0);
        EXPECT_EQ(glCheckFramebufferStatus(GL_FRAMEBUFFER), GLenum(GL_FRAMEBUFFER_COMPLETE));
    }
    gl::RgbImage draw(ui::ImGuiLayer& layer, const ui::ScreenModel& model, const ui::Strings& strings) {
        glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
        glViewport(0, 0, width_, height_);
        glClearColor(0.4f, 0.4f, 0.4f, 1.0f);
        glClear(GL_COLOR_BUFFER_BIT);
        layer.begin_frame(1.0 / 30, {});
        ui::draw_visitor_screen(model, strings, width_, height_);
        layer.end_frame();
        gl::RgbImage image{width_, height_, {}};
        std::vector<std::uint8_t> rgba(std::size_t(width_) * height_ * 4);
        glPixelStorei(GL_PACK_ALIGNMENT, 1);
        glReadPixels(0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
        image.pixels.resize(std::size_t(width_) * height_ * 3);
        for (int y = 0; y < height_; ++y)
            for (int x = 0; x < width_; ++x)
                for (int c = 0; c < 3; ++c)
                    image.pixels[(std::size_t(y) * width_ + x) * 3 + c] = rgba[(std::size_t(height_ - 1 - y) * width_ + x) * 4 + c];
        return image;
    }

private:
    int width_, height_;
    gl::GlTexture colour_ = gl::GlTexture::create();
    gl::GlFramebuffer framebuffer_ = gl::GlFramebuffer::create();
};

}  // namespace

class ScreenSizes : public UiTest, public ::testing::WithParamInterface<std::pair<int, int>> {};

TEST_P(ScreenSizes, EveryScreenFitsAndScales) {
    const auto [width, height] = GetParam();
    ui::ImGuiLayer layer(width, height);
    Offscreen frame_buffer(width, height);
    const Rgb white{255, 255, 255}, green = rgb_of(ui::colours::kProgress), track = rgb_of(ui::colours::kTrack);
    const Rgb grey{102, 102, 102};

    ui::ScreenModel m;
    for (const KioskState state : {KioskState::Attract, KioskState::Capture, KioskState::Processing, KioskState::Ar}) {
        m.state = state;
        m.capture.progress = 0.75;
        m.capture.target_x = 1;
        m.capture.minimap_width = 16, m.capture.minimap_height = 8;
        m.capture.minimap.assign(128, 200);
        m.processing.step = "processing.merging";
        m.processing.progress = 0.75;
        m.ar.material = "material.mirror";
        m.ar.tracked = true;
        const gl::RgbImage image = frame_buffer.draw(layer, m, strings());
        EXPECT_GT(count(image, white, 0, 0, width, height, 2), width * height / 2000)
            << width << "x" << height << " state " << int(state);
        // Nothing drawn within 2 pixels of the edges: every text and panel is inside the frame.
        int at_edges = 0;
        for (int x = 0; x < width; ++x)
            for (int y : {0, 1, height - 2, height - 1}) at_edges += !near(pixel(image, x, y), grey, 1);
        for (int y = 0; y < height; ++y)
            for (int x : {0, 1, width - 2, width - 1}) at_edges += !near(pixel(image, x, y), grey, 1);
        EXPECT_EQ(at_edges, 0) << width << "x" << height << " state " << int(state);
        if (state == KioskState::Capture || state == KioskState::Processing) {
            // The bar's row: the most filled pixels.
            int best_filled = 0, best_track = 0;
            for (int y = height / 2; y < height; ++y) {
                const int f = count(image, green, 0, y, width, y + 1, 2), t = count(image, track, 0, y, width, y + 1, 2);
                if (f + t > best_filled + best_track) best_filled = f, best_track = t;
            }
            ASSERT_GT(best_filled + best_track, width / 3) << width << "x" << height;
            EXPECT_NEAR(double(best_filled) / (best_filled + best_track), 0.75, 0.01) << width << "x" << height;
        }
        if (state == KioskState::Ar) {
            EXPECT_EQ(count(image, grey, width / 5, height / 5, width * 4 / 5, height * 4 / 5, 1),
                      (width * 4 / 5 - width / 5) * (height * 4 / 5 - height / 5));
        }
    }
}

INSTANTIATE_TEST_SUITE_P(Panels, ScreenSizes,
                         ::testing::Values(std::pair{800, 480}, std::pair{1024, 600}, std::pair{1920, 1080}),
                         [](const auto& p) { return std::to_string(p.param.first) + "x" + std::to_string(p.param.second); });
