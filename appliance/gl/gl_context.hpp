// The EGL display and the OpenGL ES context, apart from scanout: the KMS
// (GBM) and window displays of the AR work create their own EGLDisplay and
// surfaces and reuse GlContext on it. Everything GL runs on the thread that
// made the context current.
#pragma once

#include <EGL/egl.h>

#include <string>
#include <vector>

namespace glint::gl {

// What the context offers that the engines depend on.
struct GlCapabilities {
    int major = 0, minor = 0;          // OpenGL ES version of the context
    std::string version, renderer, vendor, glsl_version, egl_version;
    bool float_color_buffer = false;   // GL_EXT_color_buffer_float: RGBA32F render targets
    bool timer_query = false;          // GL_EXT_disjoint_timer_query: GPU time of a draw
    bool float_blend = false;          // GL_EXT_float_blend: additive blending into RGBA32F targets
    int max_draw_buffers = 1;
    int max_texture_size = 0;
    std::vector<std::string> extensions;
    bool has(const std::string& extension) const;
};

// An initialised EGL display; eglTerminate when the last EglDisplay of that handle goes. EGL hands
// out one handle per platform and native display, and one eglTerminate ends it for everyone: a
// headless display opened and closed beside the engines' context must not take theirs down.
class EglDisplay {
public:
    // Mesa's surfaceless platform (EGL_PLATFORM_SURFACELESS_MESA): rendering
    // to framebuffer objects with no window system and no DRM master; what
    // headless runs and tests use. Throws RuntimeError naming what is missing.
    static EglDisplay surfaceless();
    // Takes over an initialised display made elsewhere (KMS, window).
    explicit EglDisplay(EGLDisplay display);
    EglDisplay(EglDisplay&& other) noexcept : display_(other.display_) { other.display_ = EGL_NO_DISPLAY; }
    EglDisplay& operator=(EglDisplay&&) = delete;
    EglDisplay(const EglDisplay&) = delete;
    ~EglDisplay();
    EGLDisplay handle() const { return display_; }

private:
    EGLDisplay display_ = EGL_NO_DISPLAY;
};

// An OpenGL ES 3.x context: asks for 3.1, accepts 3.0. With no config it is
// configless (EGL_KHR_no_config_context) and renders only into framebuffer
// objects; a scanout backend passes the config of its surfaces.
class GlContext {
public:
    // share: a context whose objects (textures) this one sees too, e.g. the
    // convolution worker's context shares its maps with the renderer's.
    explicit GlContext(const EglDisplay& display, EGLConfig config = nullptr, const GlContext* share = nullptr);
    GlContext(const GlContext&) = delete;
    GlContext& operator=(const GlContext&) = delete;
    ~GlContext();

    // Makes the context current on the calling thread (with no surface).
    void make_current() const;
    // ... drawing into and reading from `surface` (a window's or a GBM surface's).
    void make_current(EGLSurface surface) const;
    const GlCapabilities& caps() const { return caps_; }
    // One line: versions, renderer, and the extensions Glint uses.
    std::string describe() const;

    EGLContext handle() const { return context_; }

private:
    EGLDisplay display_;
    EGLContext context_ = EGL_NO_CONTEXT;
    GlCapabilities caps_;
};

// "EGL_BAD_MATCH", or the code in hex.
std::string egl_error_name(EGLint error);

// Throws RuntimeError("<what>: GL error <name>") if glGetError reports one
// (all pending errors are drained).
void check_gl(const char* what);

}  // namespace glint::gl
