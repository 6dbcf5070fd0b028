// The KMS display (display.hpp): the appliance's own screen, with no display server. A DRM card
// found by enumeration, the connector and mode of choose_kms_output, a GBM surface that EGL draws
// into, and page flips one in flight at a time: atomic commits (the mode set with the first frame,
// then the primary plane's framebuffer; the plane and property ids from kms_output.hpp) where the
// driver accepts them, else the legacy API (drmModeSetCrtc for the first frame, drmModePageFlip
// after). The CRTC's previous state is restored on exit (legacy drmModeSetCrtc, which atomic
// drivers implement too), so the console comes back. While the display is open its VT is locked (vt_lock.hpp) and the
// keyboards are the kiosk's alone (evdev_keyboard.hpp); both are released after the CRTC.
#include <fcntl.h>
#include <poll.h>
#include <time.h>
#include <unistd.h>

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl3.h>
#include <gbm.h>
#include <xf86drm.h>
#include <xf86drmMode.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>

#include "appliance/core/errors.hpp"
#include "appliance/gl/display.hpp"
#include "appliance/gl/evdev_keyboard.hpp"
#include "appliance/gl/kms_output.hpp"
#include "appliance/gl/vt_lock.hpp"

namespace glint::gl {

namespace {

std::string connector_name(const drmModeConnector& c) {
    const char* type = drmModeGetConnectorTypeName(c.connector_type);
    return std::string(type ? type : "Unknown") + "-" + std::to_string(c.connector_type_id);
}

double refresh_hz(const drmModeModeInfo& m) {
    if (m.htotal == 0 || m.vtotal == 0) return m.vrefresh;
    double hz = double(m.clock) * 1000.0 / (double(m.htotal) * double(m.vtotal));
    if (m.flags & DRM_MODE_FLAG_INTERLACE) hz *= 2;
    if (m.flags & DRM_MODE_FLAG_DBLSCAN) hz /= 2;
    return hz;
}

// The card's connectors as KmsCard (kms_output.hpp), and each connector's raw modes beside it.
KmsCard read_card(int fd, const std::string& path, std::vector<std::vector<drmModeModeInfo>>& raw_modes) {
    drmModeRes* res = drmModeGetResources(fd);
    if (!res) throw RuntimeError(path + ": not a KMS device (drmModeGetResources: " + std::strerror(errno) + ")");
    KmsCard card;
    card.path = path;
    for (int i = 0; i < res->count_connectors; ++i) {
        drmModeConnector* c = drmModeGetConnector(fd, res->connectors[i]);
        if (!c) continue;
        KmsConnector k;
        k.id = c->connector_id;
        k.name = connector_name(*c);
        k.connected = c->connection == DRM_MODE_CONNECTED;
        std::vector<drmModeModeInfo> modes;
        for (int m = 0; m < c->count_modes; ++m) {
            const drmModeModeInfo& info = c->modes[m];
            k.modes.push_back({int(info.hdisplay), int(info.vdisplay), refresh_hz(info),
                               (info.type & DRM_MODE_TYPE_PREFERRED) != 0, m});
            modes.push_back(info);
        }
        if (c->encoder_id) {
            if (drmModeEncoder* e = drmModeGetEncoder(fd, c->encoder_id)) {
                k.current_crtc = e->crtc_id;
                drmModeFreeEncoder(e);
            }
        }
        for (int e = 0; e < c->count_encoders; ++e) {
            drmModeEncoder* enc = drmModeGetEncoder(fd, c->encoders[e]);
            if (!enc) continue;
            for (int j = 0; j < res->count_crtcs && j < 32; ++j)
                if ((enc->possible_crtcs & (1u << j)) &&
                    std::find(k.possible_crtcs.begin(), k.possible_crtcs.end(), res->crtcs[j]) == k.possible_crtcs.end())
                    k.possible_crtcs.push_back(res->crtcs[j]);
            drmModeFreeEncoder(enc);
        }
        card.connectors.push_back(std::move(k));
        raw_modes.push_back(std::move(modes));
        drmModeFreeConnector(c);
    }
    drmModeFreeResources(res);
    return card;
}

// The properties of one KMS object by name (kms_output.hpp).
KmsProperties read_properties(int fd, std::uint32_t id, std::uint32_t type) {
    KmsProperties out;
    drmModeObjectProperties* props = drmModeObjectGetProperties(fd, id, type);
    if (!props) return out;
    for (std::uint32_t i = 0; i < props->count_props; ++i) {
        if (drmModePropertyRes* p = drmModeGetProperty(fd, props->props[i])) {
            out[p->name] = {p->prop_id, props->prop_values[i]};
            drmModeFreeProperty(p);
        }
    }
    drmModeFreeObjectProperties(props);
    return out;
}

std::vector<KmsPlane> read_planes(int fd) {
    std::vector<KmsPlane> planes;
    drmModePlaneRes* res = drmModeGetPlaneResources(fd);
    if (!res) return planes;
    for (std::uint32_t i = 0; i < res->count_planes; ++i) {
        drmModePlane* p = drmModeGetPlane(fd, res->planes[i]);
        if (!p) continue;
        KmsPlane k;
        k.id = p->plane_id;
        k.possible_crtcs = p->possible_crtcs;
        k.formats.assign(p->formats, p->formats + p->count_formats);
        k.properties = read_properties(fd, p->plane_id, DRM_MODE_OBJECT_PLANE);
        planes.push_back(std::move(k));
        drmModeFreePlane(p);
    }
    drmModeFreePlaneResources(res);
    return planes;
}

int crtc_index_of(int fd, std::uint32_t crtc) {
    drmModeRes* res = drmModeGetResources(fd);
    if (!res) return -1;
    int index = -1;
    for (int i = 0; i < res->count_crtcs; ++i)
        if (res->crtcs[i] == crtc) index = i;
    drmModeFreeResources(res);
    return index;
}

// The lock-down (the VT lock and the keyboards), held by the display and released after its CRTC is
// restored.
struct Lockdown {
    std::unique_ptr<VtLock> vt;
    std::unique_ptr<EvdevKeyboards> keyboards;
    // Opens the keyboards again when the VT comes back (display.vt_switch = release).
    std::function<std::unique_ptr<EvdevKeyboards>()> open_keyboards;
};

void log_line(const std::string& line) { std::fprintf(stderr, "glint: %s\n", line.c_str()); }

Lockdown lock_down(const DisplayConfig& config) {
    if (config.keyboard != "grab" && config.keyboard != "shared" && config.keyboard != "none")
        throw InputError("display: unknown keyboard mode \"" + config.keyboard + "\" (grab, shared or none)");
    if (config.vt_switch != "refuse" && config.vt_switch != "release")
        throw InputError("display: unknown vt_switch \"" + config.vt_switch + "\" (refuse or release)");
    Lockdown l;
    if (config.vt != "none")
        l.vt = std::make_unique<VtLock>(open_vt_device(config.vt),
                                        VtLockOptions{config.vt_lock_switch, true, config.vt_switch == "release"});
    if (config.keyboard != "none") {
        const EvdevOptions options{config.input_dir, config.keyboard == "grab"};
        l.open_keyboards = [options] { return std::make_unique<EvdevKeyboards>(options, log_line); };
        l.keyboards = l.open_keyboards();
    }
    return l;
}

class KmsDisplay final : public Display {
public:
    KmsDisplay(int fd, std::string path, const KmsConnector& connector, const drmModeModeInfo& mode, std::uint32_t crtc,
               const std::string& kms_api, Lockdown lockdown)
        : lockdown_(std::move(lockdown)), fd_(fd), path_(std::move(path)), connector_id_(connector.id),
          connector_name_(connector.name), mode_(mode), crtc_(crtc) {
        try {
            api_required_ = kms_api == "atomic";
            if (kms_api == "legacy") api_note_ = "legacy page flips (display.kms_api)";
            else prepare_atomic();
            saved_crtc_ = drmModeGetCrtc(fd_, crtc_);
            gbm_ = gbm_create_device(fd_);
            if (!gbm_) throw RuntimeError(path_ + ": gbm_create_device failed");
            surface_gbm_ = gbm_surface_create(gbm_, mode_.hdisplay, mode_.vdisplay, GBM_FORMAT_XRGB8888,
                                              GBM_BO_USE_SCANOUT | GBM_BO_USE_RENDERING);
            if (!surface_gbm_) throw RuntimeError(path_ + ": gbm_surface_create failed for " + describe_raw_mode());
            const auto get_platform_display =
                reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
            EGLDisplay d = get_platform_display ? get_platform_display(EGL_PLATFORM_GBM_KHR, gbm_, nullptr)
                                                : eglGetDisplay(reinterpret_cast<EGLNativeDisplayType>(gbm_));
            if (d == EGL_NO_DISPLAY) throw RuntimeError(path_ + ": EGL has no display for GBM");
            EGLint major = 0, minor = 0;
            if (!eglInitialize(d, &major, &minor))
                throw RuntimeError(path_ + ": eglInitialize on GBM failed (" + egl_error_name(eglGetError()) + ")");
            egl_.emplace(d);
            const EGLConfig cfg = choose_config();
            context_ = std::make_unique<GlContext>(*egl_, cfg);
            surface_ = eglCreateWindowSurface(d, cfg, reinterpret_cast<EGLNativeWindowType>(surface_gbm_), nullptr);
            if (surface_ == EGL_NO_SURFACE)
                throw RuntimeError(path_ + ": eglCreateWindowSurface on GBM failed (" + egl_error_name(eglGetError()) + ")");
            context_->make_current(surface_);
            renderer_ = context_->caps().renderer;
        } catch (...) {
            release(false);  // the caller still owns the card's descriptor
            throw;
        }
    }
    ~KmsDisplay() override { release(true); }

    DisplayKind kind() const override { return DisplayKind::Kms; }
    std::string describe() const override {
        std::string d = "kms: " + path_ + " " + connector_name_ + " " + describe_raw_mode() + ", " + renderer_;
        d += "; " + api_note_;
        if (lockdown_.vt) d += "; " + lockdown_.vt->describe();
        if (released_) d += "; on another VT now";
        if (lockdown_.keyboards) d += "; " + std::to_string(lockdown_.keyboards->devices().size()) + " keyboard(s)";
        return d;
    }
    std::vector<InputEvent> poll_events() override {
        return lockdown_.keyboards ? lockdown_.keyboards->poll() : std::vector<InputEvent>{};
    }
    int width() const override { return mode_.hdisplay; }
    int height() const override { return mode_.vdisplay; }
    const GlContext& context() const override { return *context_; }
    void bind_frame() override {
        glBindFramebuffer(GL_FRAMEBUFFER, 0);
        glViewport(0, 0, mode_.hdisplay, mode_.vdisplay);
    }
    void present() override {
        follow_vt_switches();
        if (released_) {
            // Another VT is on screen: nothing is shown, and the frame loop is held back so that
            // it does not spin without page flips to pace it.
            const timespec pause{0, 50'000'000};
            nanosleep(&pause, nullptr);
            return;
        }
        if (!eglSwapBuffers(egl_->handle(), surface_))
            throw RuntimeError(path_ + ": eglSwapBuffers failed (" + egl_error_name(eglGetError()) + ")");
        gbm_bo* bo = gbm_surface_lock_front_buffer(surface_gbm_);
        if (!bo) throw RuntimeError(path_ + ": no front buffer to show");
        const std::uint32_t fb = framebuffer_of(bo);
        try {
            if (atomic_) present_atomic(fb);
            else present_legacy(fb);
        } catch (...) {
            gbm_surface_release_buffer(surface_gbm_, bo);
            throw;
        }
        // The buffer shown until now goes back to GBM; the new one stays locked while on screen.
        if (shown_) gbm_surface_release_buffer(surface_gbm_, shown_);
        shown_ = bo;
    }

private:
    // display.vt_switch = release (docs/lockdown.md): a switch away gives up DRM master and the
    // keyboards, then lets the kernel switch; back on screen, master is taken again (retried each
    // frame while the other VT's program still holds it), the keyboards reopened and the mode set
    // again with the next frame.
    void follow_vt_switches() {
        if (!lockdown_.vt) return;
        switch (lockdown_.vt->take_switch_request()) {
            case VtSwitchRequest::Away: give_up_screen(); break;
            case VtSwitchRequest::Back: take_back_pending_ = true; break;
            case VtSwitchRequest::None: break;
        }
        if (take_back_pending_) take_back_screen();
    }

    void give_up_screen() {
        if (flip_pending_) {
            try {
                wait_for_flip();
            } catch (const RuntimeError& e) {
                log_line(std::string("display: before a VT switch: ") + e.what());
            }
        }
        flip_pending_ = false;  // a flip that never completed: a late event must not end a later wait
        if (drmDropMaster(fd_) != 0) log_line(path_ + ": drmDropMaster: " + std::strerror(errno));
        lockdown_.keyboards.reset();
        lockdown_.vt->allow_switch_away();
        released_ = true;
        take_back_pending_ = false;
        log_line("display: " + path_ + " given up for a VT switch (DRM master and keyboards released)");
    }

    void take_back_screen() {
        if (!lockdown_.vt->on_screen()) {  // gone again before this frame: the next Back says when
            take_back_pending_ = false;
            return;
        }
        if (!drmIsMaster(fd_) && drmSetMaster(fd_) != 0) {
            if (!master_wait_logged_)
                log_line(path_ + ": back on the kiosk's VT, but not DRM master yet (" + std::strerror(errno) +
                         "): retried each frame");
            master_wait_logged_ = true;
            return;
        }
        if (lockdown_.open_keyboards) lockdown_.keyboards = lockdown_.open_keyboards();
        mode_set_ = false;  // the mode is set again with the next frame
        released_ = false;
        take_back_pending_ = false;
        master_wait_logged_ = false;
        log_line("display: " + path_ + " taken back after a VT switch");
    }

    // Atomic modesetting if the driver accepts it: the client capability, the CRTC's primary
    // plane and every property the commits set; else legacy, and why (or, with kms_api =
    // "atomic", an error naming the card).
    void prepare_atomic() {
        const auto fall_back = [&](const std::string& why) {
            if (api_required_) throw RuntimeError(path_ + ": atomic modesetting: " + why);
            api_note_ = "legacy page flips (" + why + ")";
        };
        if (drmSetClientCap(fd_, DRM_CLIENT_CAP_ATOMIC, 1) != 0) {
            fall_back("the driver has no atomic modesetting");
            return;
        }
        try {
            const std::vector<KmsPlane> planes = read_planes(fd_);
            const KmsPlane& plane = planes[choose_primary_plane(path_, planes, crtc_index_of(fd_, crtc_), crtc_,
                                                                GBM_FORMAT_XRGB8888)];
            atomic_out_ = {connector_id_, crtc_, plane.id, mode_.hdisplay, mode_.vdisplay, {}};
            properties_[plane.id] = plane.properties;
            // Planes another master left on this CRTC (a cursor, an overlay) are switched off by
            // the mode set, or they would show over the picture.
            for (const KmsPlane& other : planes) {
                const auto on = other.properties.find("CRTC_ID");
                if (other.id == plane.id || on == other.properties.end() || on->second.value != crtc_) continue;
                atomic_out_.planes_off.push_back(other.id);
                properties_[other.id] = other.properties;
            }
            properties_[connector_id_] = read_properties(fd_, connector_id_, DRM_MODE_OBJECT_CONNECTOR);
            properties_[crtc_] = read_properties(fd_, crtc_, DRM_MODE_OBJECT_CRTC);
            resolve_atomic(path_, atomic_modeset(atomic_out_, 0, 0), properties_);  // every name there
            if (drmModeCreatePropertyBlob(fd_, &mode_, sizeof mode_, &mode_blob_) != 0)
                throw RuntimeError(path_ + ": drmModeCreatePropertyBlob for the mode failed: " + std::strerror(errno));
            atomic_ = true;
            api_note_ = "atomic commits, plane " + std::to_string(plane.id);
        } catch (const RuntimeError& e) {
            drmSetClientCap(fd_, DRM_CLIENT_CAP_ATOMIC, 0);
            const std::string what = e.what();
            fall_back(what.rfind(path_ + ": ", 0) == 0 ? what.substr(path_.size() + 2) : what);
        }
    }

    // One atomic commit of `sets`; returns 0 or the errno.
    int commit(const std::vector<AtomicSet>& sets, std::uint32_t flags) {
        const std::vector<AtomicIds> ids = resolve_atomic(path_, sets, properties_);
        drmModeAtomicReq* req = drmModeAtomicAlloc();
        if (!req) throw RuntimeError(path_ + ": drmModeAtomicAlloc failed");
        for (const AtomicIds& p : ids) {
            if (drmModeAtomicAddProperty(req, p.object, p.property, p.value) < 0) {
                drmModeAtomicFree(req);
                throw RuntimeError(path_ + ": drmModeAtomicAddProperty failed");
            }
        }
        const int r = drmModeAtomicCommit(fd_, req, flags, this);
        const int e = errno;
        drmModeAtomicFree(req);
        return r == 0 ? 0 : e;
    }

    std::string master_or(int e, const std::string& call) const {
        return path_ + (e == EACCES || e == EPERM ? ": not DRM master (another program drives the card)"
                                                  : ": " + call + " failed: " + std::strerror(e));
    }

    void present_atomic(std::uint32_t fb) {
        if (!mode_set_) {
            const std::vector<AtomicSet> sets = atomic_modeset(atomic_out_, mode_blob_, fb);
            // Checked first: a driver may refuse the combination (a mode its plane cannot scale
            // to), which auto answers with the legacy calls rather than a dark screen.
            if (const int e = commit(sets, DRM_MODE_ATOMIC_TEST_ONLY | DRM_MODE_ATOMIC_ALLOW_MODESET); e != 0) {
                if (api_required_ || e == EACCES || e == EPERM) throw RuntimeError(master_or(e, "the atomic test commit"));
                atomic_ = false;
                api_note_ = std::string("legacy page flips (the atomic test commit failed: ") + std::strerror(e) + ")";
                present_legacy(fb);
                return;
            }
            if (const int e = commit(sets, DRM_MODE_ATOMIC_ALLOW_MODESET); e != 0)
                throw RuntimeError(master_or(e, "the atomic mode set"));
            mode_set_ = true;
            return;
        }
        flip_pending_ = true;
        if (const int e = commit(atomic_flip(atomic_out_, fb), DRM_MODE_ATOMIC_NONBLOCK | DRM_MODE_PAGE_FLIP_EVENT); e != 0) {
            flip_pending_ = false;
            throw RuntimeError(master_or(e, "the atomic page flip"));
        }
        wait_for_flip();
    }

    void present_legacy(std::uint32_t fb) {
        if (!mode_set_) {
            std::uint32_t connector = connector_id_;
            if (drmModeSetCrtc(fd_, crtc_, fb, 0, 0, &connector, 1, &mode_) != 0)
                throw RuntimeError(master_or(errno, "drmModeSetCrtc"));
            mode_set_ = true;
            return;
        }
        flip_pending_ = true;
        if (drmModePageFlip(fd_, crtc_, fb, DRM_MODE_PAGE_FLIP_EVENT, this) != 0) {
            const int e = errno;
            flip_pending_ = false;
            throw RuntimeError(path_ + ": drmModePageFlip failed: " + std::strerror(e));
        }
        wait_for_flip();
    }

    std::string describe_raw_mode() const {
        return describe_mode({mode_.hdisplay, mode_.vdisplay, refresh_hz(mode_), false, 0});
    }

    EGLConfig choose_config() {
        const EGLint wanted[] = {EGL_SURFACE_TYPE, EGL_WINDOW_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT,
                                 EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_DEPTH_SIZE, 24,
                                 EGL_STENCIL_SIZE, 8, EGL_NONE};
        EGLint count = 0;
        eglChooseConfig(egl_->handle(), wanted, nullptr, 0, &count);
        std::vector<EGLConfig> configs(std::size_t(std::max(count, 0)));
        if (count > 0) eglChooseConfig(egl_->handle(), wanted, configs.data(), count, &count);
        // The config whose native format is the GBM surface's: others fail at surface creation.
        for (EGLConfig c : configs) {
            EGLint id = 0;
            if (eglGetConfigAttrib(egl_->handle(), c, EGL_NATIVE_VISUAL_ID, &id) && std::uint32_t(id) == GBM_FORMAT_XRGB8888)
                return c;
        }
        throw RuntimeError(path_ + ": no EGL config renders into an XRGB8888 GBM surface");
    }

    // A KMS framebuffer per GBM buffer, made once and kept with the buffer (GBM reuses a few).
    std::uint32_t framebuffer_of(gbm_bo* bo) {
        if (void* data = gbm_bo_get_user_data(bo)) return std::uint32_t(reinterpret_cast<std::uintptr_t>(data));
        std::uint32_t fb = 0;
        const std::uint32_t handles[4] = {gbm_bo_get_handle(bo).u32, 0, 0, 0};
        const std::uint32_t strides[4] = {gbm_bo_get_stride(bo), 0, 0, 0};
        const std::uint32_t offsets[4] = {0, 0, 0, 0};
        if (drmModeAddFB2(fd_, gbm_bo_get_width(bo), gbm_bo_get_height(bo), GBM_FORMAT_XRGB8888, handles, strides,
                          offsets, &fb, 0) != 0)
            throw RuntimeError(path_ + ": drmModeAddFB2 failed: " + std::strerror(errno));
        gbm_bo_set_user_data(bo, reinterpret_cast<void*>(std::uintptr_t(fb)), [](gbm_bo* b, void* d) {
            gbm_device* dev = gbm_bo_get_device(b);
            drmModeRmFB(gbm_device_get_fd(dev), std::uint32_t(reinterpret_cast<std::uintptr_t>(d)));
        });
        return fb;
    }

    void wait_for_flip() {
        drmEventContext events{};
        events.version = 2;
        events.page_flip_handler = [](int, unsigned, unsigned, unsigned, void* self) {
            static_cast<KmsDisplay*>(self)->flip_pending_ = false;
        };
        while (flip_pending_) {
            pollfd p{fd_, POLLIN, 0};
            // A flip is due within a refresh; a second without one means the display is gone.
            const int r = poll(&p, 1, 1000);
            if (r < 0 && errno == EINTR) continue;
            if (r <= 0) throw RuntimeError(path_ + ": no page flip completed within 1 s");
            if (drmHandleEvent(fd_, &events) != 0) throw RuntimeError(path_ + ": drmHandleEvent failed");
        }
    }

    void release(bool close_card) {
        if (flip_pending_) {
            try {
                wait_for_flip();
            } catch (...) {
            }
        }
        if (saved_crtc_ && mode_set_) {
            std::uint32_t connector = connector_id_;
            drmModeSetCrtc(fd_, saved_crtc_->crtc_id, saved_crtc_->buffer_id, saved_crtc_->x, saved_crtc_->y, &connector,
                           1, &saved_crtc_->mode);
        }
        if (saved_crtc_) drmModeFreeCrtc(saved_crtc_);
        saved_crtc_ = nullptr;
        if (mode_blob_ && fd_ >= 0) drmModeDestroyPropertyBlob(fd_, mode_blob_);
        mode_blob_ = 0;
        if (egl_) destroy_egl_surface(egl_->handle(), surface_);
        context_.reset();
        egl_.reset();
        if (shown_ && surface_gbm_) gbm_surface_release_buffer(surface_gbm_, shown_);
        shown_ = nullptr;
        if (surface_gbm_) gbm_surface_destroy(surface_gbm_);
        surface_gbm_ = nullptr;
        if (gbm_) gbm_device_destroy(gbm_);
        gbm_ = nullptr;
        if (close_card && fd_ >= 0) close(fd_);
        fd_ = -1;
    }

    Lockdown lockdown_;  // first: destroyed last, after release() gave the CRTC back
    int fd_;
    std::string path_;
    std::uint32_t connector_id_;
    std::string connector_name_, renderer_;
    drmModeModeInfo mode_;
    std::uint32_t crtc_;
    drmModeCrtc* saved_crtc_ = nullptr;
    gbm_device* gbm_ = nullptr;
    gbm_surface* surface_gbm_ = nullptr;
    std::optional<EglDisplay> egl_;
    std::unique_ptr<GlContext> context_;
    EGLSurface surface_ = EGL_NO_SURFACE;
    gbm_bo* shown_ = nullptr;
    bool mode_set_ = false, flip_pending_ = false;
    // On another VT (display.vt_switch = release), and waiting to take the card back.
    bool released_ = false, take_back_pending_ = false, master_wait_logged_ = false;
    // Atomic modesetting (prepare_atomic), or legacy with api_note_ saying why.
    bool atomic_ = false, api_required_ = false;
    std::string api_note_ = "legacy page flips";
    AtomicOutput atomic_out_;
    std::map<std::uint32_t, KmsProperties> properties_;
    std::uint32_t mode_blob_ = 0;
};

}  // namespace

std::unique_ptr<Display> open_kms_display(const DisplayConfig& config) {
    if (config.kms_api != "auto" && config.kms_api != "atomic" && config.kms_api != "legacy")
        throw InputError("display: unknown kms_api \"" + config.kms_api + "\" (auto, atomic or legacy)");
    std::vector<std::string> cards;
    if (!config.card.empty()) {
        cards.push_back(config.card);
    } else {
        for (int i = 0; i < 16; ++i) {
            const std::string p = "/dev/dri/card" + std::to_string(i);
            if (std::filesystem::exists(p)) cards.push_back(p);
        }
        if (cards.empty()) throw RuntimeError("no DRM card (/dev/dri/card* does not exist)");
    }
    std::string reasons;
    for (const std::string& path : cards) {
        try {
            const int fd = open(path.c_str(), O_RDWR | O_CLOEXEC);
            if (fd < 0) throw RuntimeError(path + ": cannot open: " + std::strerror(errno));
            try {
                // The screen belongs to one program: without master rights the mode set fails later
                // with a less clear error.
                if (!drmIsMaster(fd) && drmSetMaster(fd) != 0)
                    throw RuntimeError(path + ": not DRM master (another program, e.g. a desktop, drives the card)");
                std::vector<std::vector<drmModeModeInfo>> raw;
                const KmsCard card = read_card(fd, path, raw);
                const KmsChoice choice = choose_kms_output(card, {config.connector, config.mode});
                const KmsConnector& c = card.connectors[choice.connector];
                // The VT is locked before the first frame replaces the console's picture.
                return std::make_unique<KmsDisplay>(fd, path, c, raw[choice.connector][choice.mode], choice.crtc,
                                                    config.kms_api, lock_down(config));
            } catch (...) {
                close(fd);
                throw;
            }
        } catch (const RuntimeError& e) {
            // With a named card its reason is the answer; enumerating, the next card may do.
            if (!config.card.empty()) throw;
            reasons += (reasons.empty() ? "" : "; ") + std::string(e.what());
        }
    }
    throw RuntimeError(reasons);
}

}  // namespace glint::gl
