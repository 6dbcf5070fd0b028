// The VT lock (vt_lock.hpp): graphics mode, keyboard off, switches refused; restored in reverse.
#include "appliance/gl/vt_lock.hpp"

#include <fcntl.h>
#include <linux/kd.h>
#include <linux/vt.h>
#include <signal.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "appliance/core/errors.hpp"

namespace glint::gl {

namespace {

// The kernel sends these when someone asks to switch away from (release) or back to (acquire)
// a VT in VT_PROCESS mode. Nothing else in the appliance uses them.
constexpr int kReleaseSignal = SIGUSR1;
constexpr int kAcquireSignal = SIGUSR2;
// A crash in any of these leaves the process without unwinding: the handler restores the VT first.
constexpr std::array kCrashSignals{SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT};

enum class Step { Activate, ProcessMode, LockSwitch, Graphics, KeyboardOff };
constexpr int kMaxSteps = 5;

const char* step_request_name(Step s) {
    switch (s) {
        case Step::Activate: return "VT_ACTIVATE";
        case Step::ProcessMode: return "VT_SETMODE";
        case Step::LockSwitch: return "VT_UNLOCKSWITCH";
        case Step::Graphics: return "KDSETMODE";
        case Step::KeyboardOff: return "KDSKBMODE";
    }
    return "?";
}

bool is_vt_device(const struct stat& st) {
    // /dev/tty1../dev/tty63: character major 4 (TTY_MAJOR), minors 1-63 (0 is /dev/tty0, the
    // current VT's alias, 64 and up are serial ports /dev/ttyS*).
    return S_ISCHR(st.st_mode) && major(st.st_rdev) == 4 && minor(st.st_rdev) >= 1 && minor(st.st_rdev) <= 63;
}

class RealVt final : public VtDevice {
public:
    RealVt(std::string path, int fd, int number) : path_(std::move(path)), fd_(fd), number_(number) {}
    ~RealVt() override { ::close(fd_); }
    const std::string& path() const override { return path_; }
    int number() const override { return number_; }
    int ioctl(unsigned long request, unsigned long arg) noexcept override { return ::ioctl(fd_, request, arg); }

private:
    std::string path_;
    int fd_;
    int number_;
};

std::unique_ptr<VtDevice> open_vt_path(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (fd < 0) {
        const int e = errno;
        throw RuntimeError(path + ": cannot open: " + std::strerror(e) +
                           (e == EACCES ? " (the unit's TTYPath= hands the VT to the service)" : ""));
    }
    struct stat st {};
    if (fstat(fd, &st) != 0 || !is_vt_device(st)) {
        ::close(fd);
        throw RuntimeError(path + ": not a virtual terminal (a VT is /dev/tty1 .. /dev/tty63)");
    }
    return std::make_unique<RealVt>(path, fd, int(minor(st.st_rdev)));
}

}  // namespace

std::unique_ptr<VtDevice> open_vt_device(const std::string& spec) {
    if (spec != "auto") return open_vt_path(spec);
    // Under systemd with TTYPath= and StandardInput=tty the VT is standard input, and it is the
    // process's controlling terminal, which is what lets the kiosk set its modes without
    // CAP_SYS_TTY_CONFIG.
    struct stat st {};
    if (fstat(STDIN_FILENO, &st) == 0 && is_vt_device(st)) {
        const int fd = fcntl(STDIN_FILENO, F_DUPFD_CLOEXEC, 3);
        if (fd < 0) throw RuntimeError(std::string("standard input (a VT): cannot duplicate: ") + std::strerror(errno));
        const char* name = ttyname(STDIN_FILENO);
        const int n = int(minor(st.st_rdev));
        return std::make_unique<RealVt>(name ? name : "/dev/tty" + std::to_string(n), fd, n);
    }
    // Otherwise the VT on screen now, which /dev/tty0 reports.
    const int fd0 = ::open("/dev/tty0", O_RDONLY | O_NOCTTY | O_CLOEXEC);
    if (fd0 < 0)
        throw RuntimeError(std::string("display.vt = auto: standard input is not a VT and /dev/tty0 cannot be opened (") +
                           std::strerror(errno) + "); run under the unit's TTYPath= or set display.vt");
    vt_stat state{};
    const int r = ::ioctl(fd0, VT_GETSTATE, &state);
    const int e = errno;
    ::close(fd0);
    if (r != 0) throw RuntimeError(std::string("/dev/tty0: VT_GETSTATE: ") + std::strerror(e));
    return open_vt_path("/dev/tty" + std::to_string(state.v_active));
}

struct VtLock::Saved {
    int previous_active = 0;  // the VT on screen before (0: unknown)
    long kd_mode = KD_TEXT;
    long kb_mode = K_UNICODE;
    vt_mode mode{};
    std::array<Step, kMaxSteps> done{};
    int count = 0;
    bool lock_switch = false;
    bool release_on_switch = false;
    std::atomic<bool> restored{false};
    // What went wrong while restoring, for the destructor's report (the signal path cannot print).
    std::array<int, kMaxSteps> restore_errno{};
};

namespace {

// The live lock, for the signal handlers (at most one per process).
std::atomic<VtDevice*> g_device{nullptr};
std::atomic<VtLock::Saved*> g_saved{nullptr};
// Release mode: the handler only notes the kernel's request; the frame loop answers it.
std::atomic<bool> g_release_mode{false}, g_away_requested{false}, g_back{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the switch flags are set from a signal handler");
struct sigaction g_old_release {}, g_old_acquire {};
std::array<struct sigaction, kCrashSignals.size()> g_old_crash{};

// Undoes the steps done, newest first. Only ioctls: async-signal-safe.
void undo(VtDevice& device, VtLock::Saved& saved) noexcept {
    if (saved.restored.exchange(true)) return;
    for (int i = saved.count - 1; i >= 0; --i) {
        int r = 0;
        switch (saved.done[std::size_t(i)]) {
            case Step::KeyboardOff:
                // Nothing typed while the keyboard was off may reach the getty or shell after us.
                device.ioctl(TCFLSH, TCIFLUSH);
                r = device.ioctl(KDSKBMODE, static_cast<unsigned long>(saved.kb_mode));
                break;
            case Step::Graphics: r = device.ioctl(KDSETMODE, static_cast<unsigned long>(saved.kd_mode)); break;
            case Step::LockSwitch: r = device.ioctl(VT_UNLOCKSWITCH, 0); break;
            case Step::ProcessMode: {
                // A VT that was in another program's VT_PROCESS mode goes back to VT_AUTO: setting
                // VT_PROCESS again would name this process, not that one, as its owner.
                vt_mode mode = saved.mode;
                if (mode.mode == VT_PROCESS) mode = vt_mode{};  // VT_AUTO
                r = device.ioctl(VT_SETMODE, reinterpret_cast<unsigned long>(&mode));
                break;
            }
            case Step::Activate:
                if (saved.previous_active > 0) r = device.ioctl(VT_ACTIVATE, static_cast<unsigned long>(saved.previous_active));
                break;
        }
        saved.restore_errno[std::size_t(i)] = r < 0 ? errno : 0;
    }
}

void on_switch_signal(int signal_number) {
    const int saved_errno = errno;
    if (VtDevice* device = g_device.load()) {
        if (signal_number == kReleaseSignal) {
            // Refuse mode: at once (0). Release mode: the frame loop first gives up the card and
            // keyboards, then answers (VtLock::allow_switch_away); the kernel waits for it.
            if (g_release_mode.load()) g_away_requested.store(true);
            else device->ioctl(VT_RELDISP, 0);
        } else {
            // Back on screen: acknowledged at once in both modes; release mode takes the card back
            // in the frame loop.
            device->ioctl(VT_RELDISP, VT_ACKACQ);
            if (g_release_mode.load()) g_back.store(true);
        }
    }
    errno = saved_errno;
}

void on_crash_signal(int signal_number) {
    VtLock::restore_now();
    for (std::size_t i = 0; i < kCrashSignals.size(); ++i)
        if (kCrashSignals[i] == signal_number) sigaction(signal_number, &g_old_crash[i], nullptr);
    // The earlier disposition (the default: a core dump; or a sanitizer's report) takes it from here.
    raise(signal_number);
}

void install_handlers() {
    struct sigaction a {};
    a.sa_handler = on_switch_signal;
    sigemptyset(&a.sa_mask);
    a.sa_flags = SA_RESTART;
    sigaction(kReleaseSignal, &a, &g_old_release);
    sigaction(kAcquireSignal, &a, &g_old_acquire);
    struct sigaction c {};
    c.sa_handler = on_crash_signal;
    sigemptyset(&c.sa_mask);
    c.sa_flags = SA_NODEFER;
    for (std::size_t i = 0; i < kCrashSignals.size(); ++i) sigaction(kCrashSignals[i], &c, &g_old_crash[i]);
}

void uninstall_handlers() {
    for (std::size_t i = 0; i < kCrashSignals.size(); ++i) sigaction(kCrashSignals[i], &g_old_crash[i], nullptr);
    sigaction(kReleaseSignal, &g_old_release, nullptr);
    sigaction(kAcquireSignal, &g_old_acquire, nullptr);
}

std::string failure(const VtDevice& device, const char* request, int e) {
    std::string line = device.path() + ": " + request + ": " + std::strerror(e);
    if (e == ENOTTY || e == EINVAL) line += " (not a virtual terminal, or one without this ioctl)";
    else if (e == EPERM && std::strcmp(request, "VT_LOCKSWITCH") == 0)
        line += " (needs CAP_SYS_TTY_CONFIG; or set display.vt_lock_switch = false)";
    else if (e == EPERM || e == EACCES)
        line += " (the VT must be the process's controlling terminal, the unit's TTYPath= with StandardInput=tty, "
                "or the process needs CAP_SYS_TTY_CONFIG)";
    return line;
}

}  // namespace

VtLock::VtLock(std::unique_ptr<VtDevice> device, const VtLockOptions& options)
    : device_(std::move(device)), saved_(std::make_unique<Saved>()) {
    VtDevice& d = *device_;
    Saved& s = *saved_;
    if (options.release_on_switch && options.lock_switch)
        throw InputError(d.path() + ": a VT switch cannot be both let go (display.vt_switch = release) and locked "
                                    "(display.vt_lock_switch)");
    s.lock_switch = options.lock_switch;
    s.release_on_switch = options.release_on_switch;
    const auto query = [&](unsigned long request, const char* name, void* out) {
        if (d.ioctl(request, reinterpret_cast<unsigned long>(out)) < 0) throw RuntimeError(failure(d, name, errno));
    };
    vt_stat state{};
    query(VT_GETSTATE, "VT_GETSTATE", &state);
    s.previous_active = state.v_active;
    int kd = KD_TEXT, kb = K_UNICODE;
    query(KDGETMODE, "KDGETMODE", &kd);
    query(KDGKBMODE, "KDGKBMODE", &kb);
    query(VT_GETMODE, "VT_GETMODE", &s.mode);
    s.kd_mode = kd;
    s.kb_mode = kb;

    VtDevice* expected = nullptr;
    if (!g_device.compare_exchange_strong(expected, &d))
        throw RuntimeError(d.path() + ": another VT lock is live in this process (" + expected->path() + ")");
    g_saved = &s;
    g_away_requested = false;
    g_back = false;
    g_release_mode = options.release_on_switch;
    install_handlers();
    const auto step = [&](Step done, unsigned long request, const char* name, unsigned long arg) {
        if (d.ioctl(request, arg) < 0) throw RuntimeError(failure(d, name, errno));
        s.done[std::size_t(s.count++)] = done;
    };
    try {
        if (options.activate && s.previous_active != d.number()) {
            step(Step::Activate, VT_ACTIVATE, "VT_ACTIVATE", static_cast<unsigned long>(d.number()));
            // VT_WAITACTIVE would wait for ever on a VT whose owner refuses to let go: 2 s at most.
            for (int k = 0;; ++k) {
                vt_stat now{};
                if (d.ioctl(VT_GETSTATE, reinterpret_cast<unsigned long>(&now)) == 0 && now.v_active == d.number()) break;
                if (k == 200)
                    throw RuntimeError(d.path() + ": VT " + std::to_string(s.previous_active) +
                                       " did not give up the screen within 2 s (a program holds it in VT_PROCESS mode)");
                const timespec ten_ms{0, 10'000'000};
                nanosleep(&ten_ms, nullptr);
            }
        }
        vt_mode process{};
        process.mode = VT_PROCESS;
        process.relsig = kReleaseSignal;
        process.acqsig = kAcquireSignal;
        step(Step::ProcessMode, VT_SETMODE, "VT_SETMODE", reinterpret_cast<unsigned long>(&process));
        if (options.lock_switch) step(Step::LockSwitch, VT_LOCKSWITCH, "VT_LOCKSWITCH", 0);
        step(Step::Graphics, KDSETMODE, "KDSETMODE", KD_GRAPHICS);
        // What was typed before the lock is dropped with the keyboard.
        d.ioctl(TCFLSH, TCIFLUSH);
        step(Step::KeyboardOff, KDSKBMODE, "KDSKBMODE", K_OFF);
    } catch (...) {
        undo(d, s);
        uninstall_handlers();
        g_saved = nullptr;
        g_device = nullptr;
        g_release_mode = false;
        throw;
    }
}

VtLock::~VtLock() {
    // Unpublished first, so that restore_now() on the signal thread finds no lock being torn down.
    g_saved = nullptr;
    g_device = nullptr;
    g_release_mode = false;
    // A switch away still waiting for an answer is let go: the process no longer holds the screen.
    if (g_away_requested.exchange(false)) device_->ioctl(VT_RELDISP, 1);
    undo(*device_, *saved_);
    uninstall_handlers();
    for (int i = 0; i < saved_->count; ++i)
        if (const int e = saved_->restore_errno[std::size_t(i)]; e != 0)
            std::fprintf(stderr, "glint: %s: restoring with %s failed: %s\n", device_->path().c_str(),
                         step_request_name(saved_->done[std::size_t(i)]), std::strerror(e));
}

std::string VtLock::describe() const {
    if (saved_->release_on_switch)
        return device_->path() + " (VT " + std::to_string(device_->number()) +
               "): graphics mode, keyboard off, switches let go with the card and keyboards (VT_PROCESS)";
    return device_->path() + " (VT " + std::to_string(device_->number()) +
           "): graphics mode, keyboard off, switches refused (VT_PROCESS" + (saved_->lock_switch ? ", VT_LOCKSWITCH)" : ")");
}

VtSwitchRequest VtLock::take_switch_request() {
    if (!saved_->release_on_switch) return VtSwitchRequest::None;
    // Away first: the kernel is waiting for its answer. A Back noted before it is stale: the
    // kernel acknowledged that return at once and may then have been asked to switch away again
    // (`chvt 1; chvt 2`); taken after the Away it would take the screen from the other VT.
    if (g_away_requested.load()) {
        g_back.store(false);
        return VtSwitchRequest::Away;
    }
    if (g_back.exchange(false)) return VtSwitchRequest::Back;
    return VtSwitchRequest::None;
}

bool VtLock::on_screen() const {
    vt_stat state{};
    return device_->ioctl(VT_GETSTATE, reinterpret_cast<unsigned long>(&state)) == 0 && state.v_active == device_->number();
}

void VtLock::allow_switch_away() {
    if (!g_away_requested.exchange(false)) return;
    if (device_->ioctl(VT_RELDISP, 1) < 0) throw RuntimeError(failure(*device_, "VT_RELDISP", errno));
}

void VtLock::refuse_switch_away() {
    if (!g_away_requested.exchange(false)) return;
    if (device_->ioctl(VT_RELDISP, 0) < 0) throw RuntimeError(failure(*device_, "VT_RELDISP", errno));
}

void VtLock::restore_now() noexcept {
    VtDevice* device = g_device.load();
    Saved* saved = g_saved.load();
    if (device && saved) undo(*device, *saved);
}

}  // namespace glint::gl
