#include "appliance/gl/gl_context.hpp"

#include <EGL/eglext.h>
#include <GLES3/gl3.h>

#include <algorithm>
#include <map>
#include <mutex>
#include <sstream>

#include "appliance/core/errors.hpp"

namespace glint::gl {

std::string egl_error_name(EGLint e) {
    switch (e) {
        case EGL_SUCCESS: return "EGL_SUCCESS";
        case EGL_NOT_INITIALIZED: return "EGL_NOT_INITIALIZED";
        case EGL_BAD_ACCESS: return "EGL_BAD_ACCESS";
        case EGL_BAD_ALLOC: return "EGL_BAD_ALLOC";
        case EGL_BAD_ATTRIBUTE: return "EGL_BAD_ATTRIBUTE";
        case EGL_BAD_CONFIG: return "EGL_BAD_CONFIG";
        case EGL_BAD_CONTEXT: return "EGL_BAD_CONTEXT";
        case EGL_BAD_DISPLAY: return "EGL_BAD_DISPLAY";
        case EGL_BAD_MATCH: return "EGL_BAD_MATCH";
        case EGL_BAD_PARAMETER: return "EGL_BAD_PARAMETER";
        default: {
            std::ostringstream s;
            s << "0x" << std::hex << e;
            return s.str();
        }
    }
}

namespace {

std::string gl_error_name(GLenum e) {
    switch (e) {
        case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
        case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
        case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
        case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
        case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
        default: {
            std::ostringstream s;
            s << "0x" << std::hex << e;
            return s.str();
        }
    }
}

bool has_word(const char* list, const std::string& word) {
    if (!list) return false;
    std::istringstream s(list);
    std::string w;
    while (s >> w)
        if (w == word) return true;
    return false;
}

}  // namespace

bool GlCapabilities::has(const std::string& extension) const {
    return std::find(extensions.begin(), extensions.end(), extension) != extensions.end();
}

EglDisplay EglDisplay::surfaceless() {
    const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!has_word(client, "EGL_MESA_platform_surfaceless") || !has_word(client, "EGL_EXT_platform_base"))
        throw RuntimeError("EGL: the surfaceless platform (EGL_MESA_platform_surfaceless) is not available; "
                           "install Debian's libegl-mesa0 and libgl1-mesa-dri");
    const auto get_platform_display =
        reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
    if (!get_platform_display) throw RuntimeError("EGL: eglGetPlatformDisplayEXT is missing");
    const EGLDisplay display = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display == EGL_NO_DISPLAY)
        throw RuntimeError("EGL: no surfaceless display (" + egl_error_name(eglGetError()) + ")");
    EGLint major = 0, minor = 0;
    if (!eglInitialize(display, &major, &minor))
        throw RuntimeError("EGL: eglInitialize on the surfaceless display failed (" + egl_error_name(eglGetError()) +
                           ")");
    return EglDisplay(display);
}

namespace {

// Live EglDisplay objects per handle. Never destroyed: an EglDisplay held by a static (a test
// fixture's) is destroyed after every function-local static made later.
std::mutex& display_mutex() {
    static auto* m = new std::mutex;
    return *m;
}
std::map<EGLDisplay, int>& display_users() {
    static auto* users = new std::map<EGLDisplay, int>;
    return *users;
}

}  // namespace

EglDisplay::EglDisplay(EGLDisplay display) : display_(display) {
    if (display_ == EGL_NO_DISPLAY) return;
    const std::lock_guard<std::mutex> lock(display_mutex());
    ++display_users()[display_];
}

EglDisplay::~EglDisplay() {
    if (display_ == EGL_NO_DISPLAY) return;
    const std::lock_guard<std::mutex> lock(display_mutex());
    auto it = display_users().find(display_);
    if (it != display_users().end() && --it->second > 0) return;
    if (it != display_users().end()) display_users().erase(it);
    eglTerminate(display_);
}

GlContext::GlContext(const EglDisplay& display, EGLConfig config, const GlContext* share)
    : display_(display.handle()) {
    if (!eglBindAPI(EGL_OPENGL_ES_API)) throw RuntimeError("EGL: OpenGL ES is not supported by this display");
    if (!config && !has_word(eglQueryString(display_, EGL_EXTENSIONS), "EGL_KHR_no_config_context"))
        throw RuntimeError("EGL: a context without a config needs EGL_KHR_no_config_context");
    // Ask for 3.1 (compute and more texture formats on the appliance's GPU), accept 3.0.
    for (const int minor : {1, 0}) {
        const EGLint attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, minor, EGL_NONE};
        context_ = eglCreateContext(display_, config, share ? share->handle() : EGL_NO_CONTEXT, attributes);
        if (context_ != EGL_NO_CONTEXT) break;
    }
    if (context_ == EGL_NO_CONTEXT)
        throw RuntimeError("EGL: no OpenGL ES 3.0 or 3.1 context (" + egl_error_name(eglGetError()) + ")");
    make_current();

    caps_.egl_version = eglQueryString(display_, EGL_VERSION);
    caps_.version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
    caps_.renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    caps_.vendor = reinterpret_cast<const char*>(glGetString(GL_VENDOR));
    caps_.glsl_version = reinterpret_cast<const char*>(glGetString(GL_SHADING_LANGUAGE_VERSION));
    glGetIntegerv(GL_MAJOR_VERSION, &caps_.major);
    glGetIntegerv(GL_MINOR_VERSION, &caps_.minor);
    GLint count = 0;
    glGetIntegerv(GL_NUM_EXTENSIONS, &count);
    for (GLint i = 0; i < count; ++i)
        caps_.extensions.emplace_back(reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, GLuint(i))));
    caps_.float_color_buffer = caps_.has("GL_EXT_color_buffer_float");
    caps_.timer_query = caps_.has("GL_EXT_disjoint_timer_query");
    caps_.float_blend = caps_.has("GL_EXT_float_blend");
    glGetIntegerv(GL_MAX_DRAW_BUFFERS, &caps_.max_draw_buffers);
    glGetIntegerv(GL_MAX_TEXTURE_SIZE, &caps_.max_texture_size);
    check_gl("reading the context's capabilities");
}

GlContext::~GlContext() {
    if (context_ != EGL_NO_CONTEXT) {
        eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        eglDestroyContext(display_, context_);
    }
}

void GlContext::make_current() const {
    if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
        throw RuntimeError("EGL: eglMakeCurrent failed (" + egl_error_name(eglGetError()) + ")");
}

void GlContext::make_current(EGLSurface surface) const {
    if (!eglMakeCurrent(display_, surface, surface, context_))
        throw RuntimeError("EGL: eglMakeCurrent with a surface failed (" + egl_error_name(eglGetError()) + ")");
}

std::string GlContext::describe() const {
    std::ostringstream s;
    s << "EGL " << caps_.egl_version << ", " << caps_.version << " (GLSL " << caps_.glsl_version << "), "
      << caps_.renderer << "; float colour buffers " << (caps_.float_color_buffer ? "yes" : "NO")
      << ", timer queries " << (caps_.timer_query ? "yes" : "no") << ", " << caps_.max_draw_buffers
      << " draw buffers";
    return s.str();
}

void check_gl(const char* what) {
    GLenum e = glGetError();
    if (e == GL_NO_ERROR) return;
    std::string names = gl_error_name(e);
    for (int guard = 0; guard < 16 && (e = glGetError()) != GL_NO_ERROR; ++guard) names += ", " + gl_error_name(e);
    throw RuntimeError(std::string(what) + ": GL error " + names);
}

}  // namespace glint::gl
