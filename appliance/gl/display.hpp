// Where the appliance's frames go: one interface over three displays (docs/architecture.md,
// "Displays"), so the renderer and the kiosk never know which one runs.
// - kms: the appliance itself. A DRM card found by enumeration, its connected connector and
//   preferred mode (the config may name others), a GBM surface with EGL, page flips (atomic
//   commits where the driver has them, legacy drmModePageFlip otherwise), the previous CRTC
//   restored on exit; the VT locked and the keyboards grabbed
//   while it is open (vt_lock.hpp, evdev_keyboard.hpp), keys from the keyboards.
// - window: an X11 window with EGL, for development; keyboard input.
// - headless: EGL surfaceless and an offscreen framebuffer; frames to PNG on request (tests, CI,
//   `glint replay`).
// `auto` tries them in that order and logs each attempt with its reason; falling back from kms
// marks the display degraded (the kiosk shows it in the maintenance menu).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "appliance/gl/gl_context.hpp"
#include "appliance/gl/input_event.hpp"
#include "appliance/gl/png_writer.hpp"

namespace glint::gl {

enum class DisplayKind { Kms, Window, Headless };
const char* display_kind_name(DisplayKind kind);

struct DisplayConfig {
    std::string kind = "auto";  // "auto", "kms", "window" or "headless"
    // kms: the card ("" = the first /dev/dri/card* with a connected connector), the connector
    // ("" = the first connected) and the mode ("" = preferred; "1920x1080" or "1920x1080@60").
    std::string card, connector, mode;
    // kms: "auto" (atomic commits where the driver accepts them, else the legacy calls, saying
    // why in describe()), "atomic" (fail without them) or "legacy".
    std::string kms_api = "auto";
    // window and headless: the frame's size in pixels.
    int width = 1280, height = 720;
    bool fullscreen = false;  // window: ask the window manager for full screen
    // kms, the lock-down (docs/lockdown.md): the VT held in graphics mode with its keyboard off and
    // switches refused while the picture shows ("auto": standard input when it is a VT, else the
    // active one; "none": left alone; or "/dev/ttyN"), with the kernel's global switch lock too
    // when vt_lock_switch (needs CAP_SYS_TTY_CONFIG).
    std::string vt = "auto";
    bool vt_lock_switch = false;
    // kms: a switch to another VT is "refuse"d, or let go ("release": the card and keyboards given
    // up until the VT is back on screen; not with vt_lock_switch).
    std::string vt_switch = "refuse";
    // kms: the evdev keyboards in input_dir: "grab" (read by the kiosk alone), "shared" (read beside
    // other readers, for development) or "none".
    std::string keyboard = "grab";
    std::string input_dir = "/dev/input";
};

// One try of `auto` (or the one of an explicit kind).
struct DisplayAttempt {
    DisplayKind kind = DisplayKind::Headless;
    bool ok = false;
    std::string detail;  // what was opened, or why not (one line)
};

class Display {
public:
    virtual ~Display() = default;
    virtual DisplayKind kind() const = 0;
    virtual std::string describe() const = 0;  // "kms: /dev/dri/card0 HDMI-A-1 1920x1080@60.00"
    virtual int width() const = 0;
    virtual int height() const = 0;
    // The context every frame is drawn with, current on the thread that opened the display.
    virtual const GlContext& context() const = 0;
    // Binds the framebuffer the next frame is drawn into and sets the viewport to the whole of it.
    virtual void bind_frame() = 0;
    // Shows the frame drawn since the last present: a swap (window), a page flip that is waited
    // for (kms: at most one flip in flight), or the end of the GL work (headless).
    virtual void present() = 0;
    // Input since the last call (window: keys, the close button; kms: keys; headless: none).
    virtual std::vector<InputEvent> poll_events() { return {}; }
    // Fell back from the kind asked for (auto without KMS).
    bool degraded() const { return degraded_; }
    void set_degraded(bool degraded) { degraded_ = degraded; }

    // The frame drawn since the last present (call before present()), rows top first.
    RgbImage read_frame();

private:
    bool degraded_ = false;
};

// Unbinds the context from `surface` and destroys it (a window's or a GBM surface's); no-op for
// EGL_NO_SURFACE. Leaves `surface` EGL_NO_SURFACE.
void destroy_egl_surface(EGLDisplay display, EGLSurface& surface);

// Opens the display of `config`. Every attempt is appended to `attempts` (when given). Throws
// RuntimeError with the reason of the last attempt when none opened.
std::unique_ptr<Display> open_display(const DisplayConfig& config, std::vector<DisplayAttempt>* attempts = nullptr);

// The single kinds (open_display calls these).
std::unique_ptr<Display> open_headless_display(const DisplayConfig& config);
std::unique_ptr<Display> open_window_display(const DisplayConfig& config);  // needs $DISPLAY
std::unique_ptr<Display> open_kms_display(const DisplayConfig& config);

}  // namespace glint::gl
