// One headless 1280x720 display (llvmpipe), one ImGui layer and the shipped strings for all the
// screen tests; a frame is a stand-in 3D image (a sky gradient over a checker floor, drawn with
// the project's textured_quad program) with the overlay drawn over it and read back.
#pragma once

#include <gtest/gtest.h>

#include <GLES3/gl3.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "appliance/gl/display.hpp"
#include "appliance/gl/gl_objects.hpp"
#include "appliance/gl/gl_program.hpp"
#include "appliance/gl/png_writer.hpp"
#include "appliance/ui/imgui_layer.hpp"
#include "appliance/ui/strings.hpp"

namespace glint::test {

inline constexpr int kWidth = 1280, kHeight = 720;

struct Rgb {
    int r = 0, g = 0, b = 0;
};
inline Rgb rgb_of(std::uint32_t imgui_colour) {  // IM_COL32 packs A B G R from the top byte
    return {int(imgui_colour & 0xFF), int((imgui_colour >> 8) & 0xFF), int((imgui_colour >> 16) & 0xFF)};
}
inline Rgb pixel(const gl::RgbImage& image, int x, int y) {
    const std::uint8_t* p = image.at(x, y);
    return {p[0], p[1], p[2]};
}
inline bool near(Rgb a, Rgb b, int tolerance = 3) {
    return std::abs(a.r - b.r) <= tolerance && std::abs(a.g - b.g) <= tolerance && std::abs(a.b - b.b) <= tolerance;
}
inline double luminance(Rgb c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

// Pixels of `colour` in the rectangle [x0, x1) x [y0, y1).
inline int count(const gl::RgbImage& image, Rgb colour, int x0, int y0, int x1, int y1, int tolerance = 3) {
    int n = 0;
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) n += near(pixel(image, x, y), colour, tolerance);
    return n;
}

class UiTest : public ::testing::Test {
public:
    static void SetUpTestSuite() {
        if (!display_) {
            gl::DisplayConfig config;
            config.kind = "headless";
            config.width = kWidth;
            config.height = kHeight;
            display_ = gl::open_headless_display(config);
            layer_ = std::make_unique<ui::ImGuiLayer>(kWidth, kHeight);
            strings_ = std::make_unique<ui::Strings>(
                ui::Strings::load(std::filesystem::path(GLINT_SOURCE_DIR) / ui::kStringsRelativePath));
            make_background();
        }
        display_->context().make_current();
    }

    static gl::Display& display() { return *display_; }
    static ui::ImGuiLayer& layer() { return *layer_; }
    static const ui::Strings& strings() { return *strings_; }

    // The stand-in 3D frame, then one ImGui frame with `draw` inside, read back. `frames` > 1
    // runs the ImGui frame that many times (windows size themselves on their first frame) and
    // keeps the last. With GLINT_WRITE_SCREENSHOTS=DIR and a name, saves DIR/<name>.png.
    static gl::RgbImage frame(const std::function<void()>& draw, const std::string& name = "", int frames = 1,
                              const std::vector<gl::InputEvent>& keys = {}) {
        gl::RgbImage image;
        for (int k = 0; k < frames; ++k) {
            display_->bind_frame();
            draw_background();
            layer_->begin_frame(1.0 / 30.0, k == 0 ? keys : std::vector<gl::InputEvent>{});
            draw();
            layer_->end_frame();
        }
        image = display_->read_frame();
        display_->present();
        if (const char* dir = std::getenv("GLINT_WRITE_SCREENSHOTS"); dir != nullptr && *dir != 0 && !name.empty()) {
            std::filesystem::create_directories(dir);
            gl::save_png(std::filesystem::path(dir) / (name + ".png"), image);
        }
        return image;
    }

    static void draw_background() {
        glDisable(GL_BLEND);
        glDisable(GL_SCISSOR_TEST);
        background_program_->use();
        glActiveTexture(GL_TEXTURE0);
        glBindTexture(GL_TEXTURE_2D, background_.id());
        glUniform1i(background_program_->uniform("u_image"), 0);
        glDrawArrays(GL_TRIANGLES, 0, 3);
    }

private:
    // A sky that darkens upwards over a checker floor: only vertical gradients and flat squares, so
    // the screenshots stay small, and none of the overlay's exact colours.
    static void make_background() {
        std::vector<std::uint8_t> rgba(std::size_t(kWidth) * kHeight * 4);
        const int horizon = kHeight * 3 / 5, square = 48;
        for (int y = 0; y < kHeight; ++y) {
            for (int x = 0; x < kWidth; ++x) {
                std::uint8_t* p = &rgba[(std::size_t(y) * kWidth + std::size_t(x)) * 4];
                if (y < horizon) {
                    const double t = double(y) / horizon;
                    p[0] = std::uint8_t(60 + 90 * t);
                    p[1] = std::uint8_t(80 + 80 * t);
                    p[2] = std::uint8_t(120 + 50 * t);
                } else {
                    const bool dark = ((x / square) + ((y - horizon) / square)) % 2 == 0;
                    p[0] = dark ? 92 : 128;
                    p[1] = dark ? 84 : 116;
                    p[2] = dark ? 76 : 104;
                }
                p[3] = 255;
            }
        }
        background_ = gl::GlTexture::create();
        glBindTexture(GL_TEXTURE_2D, background_.id());
        glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, kWidth, kHeight, 0, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
        background_program_ = std::make_unique<gl::GlProgram>("textured_quad.vert", "textured_quad.frag");
    }

    static inline std::unique_ptr<gl::Display> display_;
    static inline std::unique_ptr<ui::ImGuiLayer> layer_;
    static inline std::unique_ptr<ui::Strings> strings_;
    static inline gl::GlTexture background_;
    static inline std::unique_ptr<gl::GlProgram> background_program_;
};

}  // namespace glint::test
