// The window display (display.hpp): an X11 window with an EGL window surface, for development
// and for screenshots under Xvfb; keys come from X11 KeyPress/KeyRelease events.
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>

#include <memory>
#include <optional>
#include <string>

#include "appliance/core/errors.hpp"
#include "appliance/gl/display.hpp"

// Xlib last: it defines macros (None, Bool, Status) that other headers' names collide with.
#include <X11/Xlib.h>
#include <X11/Xatom.h>
#include <X11/Xutil.h>

namespace glint::gl {

namespace {

EGLDisplay x11_egl_display(::Display* x) {
    // The platform call says which window system the pointer is; eglGetDisplay would have to guess.
    const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    const bool platform_x11 = client && std::string(client).find("EGL_EXT_platform_x11") != std::string::npos;
    const auto get_platform_display =
        reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
    EGLDisplay d = platform_x11 && get_platform_display ? get_platform_display(EGL_PLATFORM_X11_EXT, x, nullptr)
                                                        : eglGetDisplay(reinterpret_cast<EGLNativeDisplayType>(x));
    if (d == EGL_NO_DISPLAY) throw RuntimeError("EGL has no display for this X server");
    EGLint major = 0, minor = 0;
    if (!eglInitialize(d, &major, &minor))
        throw RuntimeError("eglInitialize on the X11 display failed (" + egl_error_name(eglGetError()) + ")");
    return d;
}

class WindowDisplay final : public Display {
public:
    explicit WindowDisplay(const DisplayConfig& config) : width_(config.width), height_(config.height) {
        const char* name = std::getenv("DISPLAY");
        display_name_ = name ? name : "";
        x_ = XOpenDisplay(nullptr);
        if (!x_) throw RuntimeError("cannot open X display \"" + display_name_ + "\"");
        try {
            egl_.emplace(x11_egl_display(x_));
            const EGLint wanted[] = {EGL_SURFACE_TYPE, EGL_WINDOW_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT,
                                     EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_DEPTH_SIZE, 24,
                                     EGL_STENCIL_SIZE, 8, EGL_NONE};
            EGLConfig cfg = nullptr;
            EGLint count = 0;
            if (!eglChooseConfig(egl_->handle(), wanted, &cfg, 1, &count) || count < 1)
                throw RuntimeError("X display \"" + display_name_ + "\": no EGL config for an OpenGL ES 3 window");
            EGLint visual_id = 0;
            eglGetConfigAttrib(egl_->handle(), cfg, EGL_NATIVE_VISUAL_ID, &visual_id);
            XVisualInfo want{};
            want.visualid = VisualID(visual_id);
            int visuals = 0;
            XVisualInfo* info = XGetVisualInfo(x_, VisualIDMask, &want, &visuals);
            if (!info || visuals < 1) throw RuntimeError("X display \"" + display_name_ + "\": no visual for the EGL config");
            const Window root = RootWindow(x_, info->screen);
            XSetWindowAttributes attributes{};
            colormap_ = XCreateColormap(x_, root, info->visual, AllocNone);
            attributes.colormap = colormap_;
            attributes.event_mask = KeyPressMask | KeyReleaseMask | StructureNotifyMask | ExposureMask;
            window_ = XCreateWindow(x_, root, 0, 0, unsigned(width_), unsigned(height_), 0, info->depth, InputOutput,
                                    info->visual, CWColormap | CWEventMask, &attributes);
            XFree(info);
            XStoreName(x_, window_, "Glint");
            delete_atom_ = XInternAtom(x_, "WM_DELETE_WINDOW", False);
            XSetWMProtocols(x_, window_, &delete_atom_, 1);
            if (config.fullscreen) {
                const Atom state = XInternAtom(x_, "_NET_WM_STATE", False);
                const Atom full = XInternAtom(x_, "_NET_WM_STATE_FULLSCREEN", False);
                XChangeProperty(x_, window_, state, XA_ATOM, 32, PropModeReplace,
                                reinterpret_cast<const unsigned char*>(&full), 1);
            }
            XMapWindow(x_, window_);
            XSync(x_, False);
            context_ = std::make_unique<GlContext>(*egl_, cfg);
            surface_ = eglCreateWindowSurface(egl_->handle(), cfg, static_cast<EGLNativeWindowType>(window_), nullptr);
            if (surface_ == EGL_NO_SURFACE)
                throw RuntimeError("X display \"" + display_name_ + "\": eglCreateWindowSurface failed (" +
                                   egl_error_name(eglGetError()) + ")");
            context_->make_current(surface_);
            renderer_ = context_->caps().renderer;
        } catch (...) {
            release();
            throw;
        }
    }
    ~WindowDisplay() override { release(); }

    DisplayKind kind() const override { return DisplayKind::Window; }
    std::string describe() const override {
        return "window: X display \"" + display_name_ + "\", " + std::to_string(width_) + "x" +
               std::to_string(height_) + ", " + renderer_;
    }
    int width() const override { return width_; }
    int height() const override { return height_; }
    const GlContext& context() const override { return *context_; }
    void bind_frame() override {
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        glViewport(0, 0, width_, height_);
    }
    void present() override {
        if (!eglSwapBuffers(egl_->handle(), surface_))
            throw RuntimeError("window: eglSwapBuffers failed (" + egl_error_name(eglGetError()) + ")");
    }
    std::vector<InputEvent> poll_events() override {
        std::vector<InputEvent> events;
        while (XPending(x_) > 0) {
            XEvent e;
            XNextEvent(x_, &e);
            if (e.type == KeyPress || e.type == KeyRelease) {
                const KeySym sym = XLookupKeysym(&e.xkey, 0);
                const char* key = sym != NoSymbol ? XKeysymToString(sym) : nullptr;
                if (key) events.push_back({e.type == KeyPress ? InputEvent::Type::KeyDown : InputEvent::Type::KeyUp, key});
            } else if (e.type == ClientMessage && Atom(e.xclient.data.l[0]) == delete_atom_) {
                events.push_back({InputEvent::Type::Quit, ""});
            } else if (e.type == ConfigureNotify) {
                // The window manager may give another size than asked (a tiling WM, full screen):
                // the frame follows the window.
                width_ = e.xconfigure.width;
                height_ = e.xconfigure.height;
            }
        }
        return events;
    }

private:
    void release() {
        if (egl_) destroy_egl_surface(egl_->handle(), surface_);
        context_.reset();
        egl_.reset();
        if (x_) {
            if (window_) XDestroyWindow(x_, window_);
            if (colormap_) XFreeColormap(x_, colormap_);
            XCloseDisplay(x_);
            x_ = nullptr;
        }
    }

    int width_, height_;
    std::string display_name_, renderer_;
    ::Display* x_ = nullptr;
    Window window_ = 0;
    Colormap colormap_ = 0;
    Atom delete_atom_ = 0;
    std::optional<EglDisplay> egl_;
    std::unique_ptr<GlContext> context_;
    EGLSurface surface_ = EGL_NO_SURFACE;
};

}  // namespace

std::unique_ptr<Display> open_window_display(const DisplayConfig& config) {
    if (config.width < 16 || config.height < 16 || config.width > 8192 || config.height > 8192)
        throw InputError("window display: size " + std::to_string(config.width) + "x" + std::to_string(config.height) +
                         " is outside 16x16 .. 8192x8192");
    return std::make_unique<WindowDisplay>(config);
}

}  // namespace glint::gl
