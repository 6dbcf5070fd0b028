// The display interface's shared parts, the headless display and `auto` (display.hpp).
#include "appliance/gl/display.hpp"

#include <GLES3/gl3.h>

#include <cstdlib>

#include "appliance/core/errors.hpp"
#include "appliance/gl/gl_objects.hpp"

namespace glint::gl {

const char* display_kind_name(DisplayKind kind) {
    switch (kind) {
        case DisplayKind::Kms: return "kms";
        case DisplayKind::Window: return "window";
        case DisplayKind::Headless: return "headless";
    }
    return "?";
}

void destroy_egl_surface(EGLDisplay display, EGLSurface& surface) {
    if (surface == EGL_NO_SURFACE) return;
    eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroySurface(display, surface);
    surface = EGL_NO_SURFACE;
}

RgbImage Display::read_frame() {
    bind_frame();
    RgbImage image;
    image.width = width();
    image.height = height();
    std::vector<std::uint8_t> rgba(std::size_t(image.width) * std::size_t(image.height) * 4);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadPixels(0, 0, image.width, image.height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
    check_gl("reading the frame back");
    image.pixels.resize(std::size_t(image.width) * std::size_t(image.height) * 3);
    for (int y = 0; y < image.height; ++y) {
        // GL's rows are bottom first.
        const std::uint8_t* src = &rgba[std::size_t(image.height - 1 - y) * std::size_t(image.width) * 4];
        std::uint8_t* dst = &image.pixels[std::size_t(y) * std::size_t(image.width) * 3];
        for (int x = 0; x < image.width; ++x)
            for (int c = 0; c < 3; ++c) dst[3 * x + c] = src[4 * x + c];
    }
    return image;
}

namespace {

void check_size(const DisplayConfig& config, const char* kind) {
    if (config.width < 16 || config.height < 16 || config.width > 8192 || config.height > 8192)
        throw InputError(std::string(kind) + " display: size " + std::to_string(config.width) + "x" +
                         std::to_string(config.height) + " is outside 16x16 .. 8192x8192");
}

// EGL surfaceless, an offscreen RGBA8 colour buffer with depth and stencil.
class HeadlessDisplay final : public Display {
public:
    explicit HeadlessDisplay(const DisplayConfig& config)
        : width_(config.width), height_(config.height), egl_(EglDisplay::surfaceless()), context_(egl_),
          framebuffer_(GlFramebuffer::create()) {
        glGenRenderbuffers(2, buffers_);
        glBindRenderbuffer(GL_RENDERBUFFER, buffers_[0]);
        glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width_, height_);
        glBindRenderbuffer(GL_RENDERBUFFER, buffers_[1]);
        glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH24_STENCIL8, width_, height_);
        glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
        glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, buffers_[0]);
        glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, buffers_[1]);
        if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
            throw RuntimeError("headless display: the " + std::to_string(width_) + "x" + std::to_string(height_) +
                               " framebuffer is incomplete");
        check_gl("creating the headless framebuffer");
    }
    ~HeadlessDisplay() override {
        context_.make_current();
        glDeleteRenderbuffers(2, buffers_);
    }
    DisplayKind kind() const override { return DisplayKind::Headless; }
    std::string describe() const override {
        return "headless: " + std::to_string(width_) + "x" + std::to_string(height_) + " offscreen, " +
               context_.caps().renderer;
    }
    int width() const override { return width_; }
    int height() const override { return height_; }
    const GlContext& context() const override { return context_; }
    void bind_frame() override {
        glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
        glViewport(0, 0, width_, height_);
    }
    void present() override { glFinish(); }

private:
    int width_, height_;
    EglDisplay egl_;
    GlContext context_;
    GlFramebuffer framebuffer_;
    GLuint buffers_[2] = {0, 0};
};

}  // namespace

std::unique_ptr<Display> open_headless_display(const DisplayConfig& config) {
    check_size(config, "headless");
    return std::make_unique<HeadlessDisplay>(config);
}

std::unique_ptr<Display> open_display(const DisplayConfig& config, std::vector<DisplayAttempt>* attempts) {
    std::vector<DisplayKind> order;
    if (config.kind == "auto") order = {DisplayKind::Kms, DisplayKind::Window, DisplayKind::Headless};
    else if (config.kind == "kms") order = {DisplayKind::Kms};
    else if (config.kind == "window") order = {DisplayKind::Window};
    else if (config.kind == "headless") order = {DisplayKind::Headless};
    else throw InputError("display: unknown kind \"" + config.kind + "\" (auto, kms, window or headless)");
    std::string last;
    for (const DisplayKind kind : order) {
        DisplayAttempt attempt;
        attempt.kind = kind;
        std::unique_ptr<Display> display;
        try {
            if (kind == DisplayKind::Window && config.kind == "auto" && !std::getenv("DISPLAY"))
                throw RuntimeError("no display server ($DISPLAY is not set)");
            display = kind == DisplayKind::Kms      ? open_kms_display(config)
                      : kind == DisplayKind::Window ? open_window_display(config)
                                                    : open_headless_display(config);
            attempt.ok = true;
            attempt.detail = display->describe();
        } catch (const std::exception& e) {
            attempt.detail = e.what();
            last = std::string(display_kind_name(kind)) + ": " + e.what();
        }
        if (attempts) attempts->push_back(attempt);
        if (display) {
            // The appliance is meant to drive its screen through KMS; anything else under auto is
            // a fallback someone should look at.
            display->set_degraded(config.kind == "auto" && kind != DisplayKind::Kms);
            return display;
        }
    }
    throw RuntimeError("no display could be opened; " + last);
}

}  // namespace glint::gl
