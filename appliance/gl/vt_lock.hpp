// The kiosk's virtual terminal, locked while the KMS display shows the picture (docs/lockdown.md).
//
// On the appliance nothing a visitor presses may reach a shell and no console text may appear over
// the picture. The VT the kiosk runs on is therefore put in graphics mode (KDSETMODE KD_GRAPHICS:
// the console stops drawing), its keyboard is switched off (KDSKBMODE K_OFF: no key reaches the
// tty's line discipline), and switches away from it are refused (VT_SETMODE VT_PROCESS: the kernel
// asks the process, which says no; optionally VT_LOCKSWITCH, the kernel's global switch lock, which
// needs CAP_SYS_TTY_CONFIG), or, in release mode, let go once the display has given up the card
// and the keyboards (take_switch_request, allow_switch_away). Everything is restored in reverse order when the lock ends, when a
// step fails half-way, and from a crash's signal handler (restore_now()).
//
// The ioctls go through VtDevice so that the unit tests check the sequence and the restore order
// against a simulated VT (tests/lockdown/fake_vt.hpp); open_vt_device() is the real one.
#pragma once

#include <memory>
#include <string>

namespace glint::gl {

// One virtual terminal, /dev/ttyN.
class VtDevice {
public:
    virtual ~VtDevice() = default;
    virtual const std::string& path() const = 0;
    virtual int number() const = 0;  // N of /dev/ttyN (1..63)
    // One ioctl(2) on the VT: 0 or more on success, -1 with errno set on failure. Must not throw,
    // allocate or lock: restore_now() calls it from a signal handler.
    virtual int ioctl(unsigned long request, unsigned long arg) noexcept = 0;
};

// Opens the VT of `spec`: "auto" (standard input when it is a VT, as under the unit's TTYPath=,
// else the active VT found through /dev/tty0) or a path such as "/dev/tty1". Throws RuntimeError
// with one line naming the device: cannot open, not a virtual terminal.
std::unique_ptr<VtDevice> open_vt_device(const std::string& spec);

struct VtLockOptions {
    // VT_LOCKSWITCH as well as VT_PROCESS: needs CAP_SYS_TTY_CONFIG, and the kernel's lock is
    // global (it outlives a SIGKILLed process; docs/lockdown.md).
    bool lock_switch = false;
    // When the VT is not the one on screen: switch to it first and back at the end.
    bool activate = true;
    // A switch away (`chvt 2` over SSH, a console a technician asks for) is let go once the caller
    // has given up the card and the keyboards (take_switch_request(), allow_switch_away()), and the
    // VT is taken back when it returns. false: every switch away is refused. Not with lock_switch
    // (the kernel would refuse before asking).
    bool release_on_switch = false;
};

// What the kernel asked of a VT in release mode since the last take_switch_request().
enum class VtSwitchRequest {
    None,
    Away,  // a switch away waits for allow_switch_away() or refuse_switch_away()
    Back,  // the VT is on screen again (already acknowledged to the kernel)
};

// The lock itself: the constructor applies the steps, the destructor restores them in reverse.
// One per process at a time (the crash path restores "the" lock).
class VtLock {
public:
    VtLock(std::unique_ptr<VtDevice> device, const VtLockOptions& options);
    ~VtLock();
    VtLock(const VtLock&) = delete;
    VtLock& operator=(const VtLock&) = delete;

    // "/dev/tty1 (VT 1): graphics mode, keyboard off, switches refused"
    std::string describe() const;

    // Release mode (VtLockOptions::release_on_switch): the switch asked for since the last call
    // (the kernel's signals only set flags; this is called from the frame loop). An Away pending
    // wins and drops a Back noted before it (a return the kernel was told of at once, followed by
    // a new switch away before the frame loop looked). Always None in refuse mode.
    VtSwitchRequest take_switch_request();
    // Whether the VT is the one on screen now (VT_GETSTATE).
    bool on_screen() const;
    // Lets the pending switch away go ahead (VT_RELDISP 1), or refuses it (VT_RELDISP 0). Throws
    // RuntimeError naming the device if the kernel refuses the answer.
    void allow_switch_away();
    void refuse_switch_away();
    // Restores the live lock, if any, at once; async-signal-safe (only the device's ioctls). The
    // crash handlers call it, and so does a signal that ends the process without unwinding
    // (app/interrupt.cpp). Idempotent: the destructor then has nothing left to do.
    static void restore_now() noexcept;

    struct Saved;  // what the VT had before (vt_lock.cpp)

private:
    std::unique_ptr<VtDevice> device_;
    std::unique_ptr<Saved> saved_;
};

}  // namespace glint::gl
