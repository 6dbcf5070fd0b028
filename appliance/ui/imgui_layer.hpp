// Dear ImGui on the appliance's GLES 3 context (docs/screens.md, "The ImGui layer"): one ImGui
// context per layer, DejaVu Sans (+ Bold) rasterised by FreeType at sizes chosen from the display's
// height, and our own renderer of ImGui's draw data (one program from shaders/imgui.*, a vertex and
// an index buffer, the font atlas as an R8 texture, a scissor per command, straight alpha). Debian's
// prebuilt OpenGL3 backend is not used: it loads desktop GL through its own loader.
//
// A frame: begin_frame(dt, keys) ... ImGui calls, draw lists ... end_frame(), which draws into the
// framebuffer bound at that moment, over what is there, and restores the GL state it changed.
// Create, use and destroy the layer with the GL context current.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "appliance/gl/display.hpp"

struct ImGuiContext;
struct ImFont;

namespace glint::ui {

// Debian's fonts-dejavu-core.
struct FontFiles {
    std::filesystem::path regular = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
    std::filesystem::path bold = "/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf";
};

enum class FontRole : std::uint8_t {
    Title,  // bold: the call to press the button, "Slower"
    Body,   // the visitor's texts: steps, material names, messages
    Small,  // time left, exposure status, the degraded mark
    Menu,   // the technician's menu (read at arm's length)
};

// Pixel sizes (em) of each role for a display `height` pixels tall. Visitor text is sized for a
// reader 2 m away from a 1080p screen: body = height / 18 (60 px at 1080p, whose DejaVu capitals
// are 44 px: 16 mm on a 32" panel, 1/125 of the distance, above the 1/200 that signage takes as
// legible), title = height / 10, small = height / 30, menu = height / 40 (27 px at 1080p).
struct FontSizes {
    float title = 0, body = 0, small = 0, menu = 0;
};
FontSizes font_sizes_for_height(int height);

class ImGuiLayer {
public:
    // Throws RuntimeError naming the font file when one is missing or FreeType cannot read it, or
    // when the atlas is larger than the context's textures may be.
    ImGuiLayer(int width, int height, const FontFiles& fonts = {});
    ~ImGuiLayer();
    ImGuiLayer(const ImGuiLayer&) = delete;
    ImGuiLayer& operator=(const ImGuiLayer&) = delete;

    // Starts an ImGui frame (makes this layer's ImGui context current). `keys`: this frame's input
    // (X11 keysym names): arrows, Tab, space, Return, Escape, BackSpace, Delete move ImGui's
    // keyboard navigation and text fields; digits, letters and the keypad's digits are typed.
    // A key pressed and released within one batch is held down for this frame and released at
    // the next, so ImGui sees the press.
    void begin_frame(double dt_s, const std::vector<gl::InputEvent>& keys);
    // Ends the frame and draws it into the bound framebuffer (the layer's width x height).
    void end_frame();

    ImFont* font(FontRole role) const;
    float font_size(FontRole role) const;
    const FontSizes& font_sizes() const { return sizes_; }
    int width() const { return width_; }
    int height() const { return height_; }
    ImGuiContext* context() const { return context_; }
    // The layer whose frame is open (between begin_frame and end_frame); throws RuntimeError
    // outside a frame. The screens and the menu take their fonts from it.
    static const ImGuiLayer& current();

    // The last end_frame(): triangles drawn and draw calls issued.
    struct FrameStats {
        int triangles = 0;
        int draw_calls = 0;
    };
    FrameStats last_frame() const { return stats_; }

private:
    struct Renderer;
    void render();

    int width_, height_;
    FontSizes sizes_;
    ImGuiContext* context_ = nullptr;
    ImFont* fonts_[4] = {};
    std::unique_ptr<Renderer> renderer_;
    std::vector<int> release_next_frame_;  // key indices pressed and released within one batch
    FrameStats stats_;
};

}  // namespace glint::ui
