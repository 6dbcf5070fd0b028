// The VT lock (appliance/gl/vt_lock.hpp) against a simulated VT: the sequence, the restore order,
// a step failing half-way, the errors' wording, the switch signals and the crash path.
#include <fcntl.h>
#include <pty.h>
#include <signal.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

#include "appliance/core/errors.hpp"
#include "appliance/gl/vt_lock.hpp"
#include "tests/lockdown/fake_vt.hpp"

namespace glint::test {
namespace {

using Log = std::vector<std::string>;

std::unique_ptr<FakeVt> fake(FakeVtState& s, int number = 1) { return std::make_unique<FakeVt>(s, number); }

TEST(VtLock, LocksInOrderAndRestoresInReverse) {
    FakeVtState s;
    {
        gl::VtLock lock(fake(s), {.lock_switch = true, .activate = true});
        EXPECT_EQ(s.kd, KD_GRAPHICS);
        EXPECT_EQ(s.kb, K_OFF);
        EXPECT_EQ(s.mode.mode, VT_PROCESS);
        EXPECT_EQ(s.mode.relsig, SIGUSR1);
        EXPECT_EQ(s.mode.acqsig, SIGUSR2);
        EXPECT_TRUE(s.switch_locked);
        EXPECT_EQ(lock.describe(), "/dev/tty1 (VT 1): graphics mode, keyboard off, switches refused (VT_PROCESS, VT_LOCKSWITCH)");
        EXPECT_EQ(s.log, (Log{"VT_SETMODE process 10 12", "VT_LOCKSWITCH", "KDSETMODE graphics", "TCFLSH", "KDSKBMODE off"}));
        s.log.clear();
    }
    // Reverse order: the keyboard first (after dropping what was typed), the console's text last
    // but one, the switch mode last.
    EXPECT_EQ(s.log, (Log{"TCFLSH", "KDSKBMODE unicode", "KDSETMODE text", "VT_UNLOCKSWITCH", "VT_SETMODE auto 0 0"}));
    EXPECT_EQ(s.kd, KD_TEXT);
    EXPECT_EQ(s.kb, K_UNICODE);
    EXPECT_EQ(s.mode.mode, VT_AUTO);
    EXPECT_FALSE(s.switch_locked);
}

TEST(VtLock, RestoresWhatTheVtHadBefore) {
    FakeVtState s;
    s.kb = K_XLATE;  // a console without Unicode
    { gl::VtLock lock(fake(s), {}); }
    EXPECT_EQ(s.kb, K_XLATE);
    EXPECT_EQ(s.log, (Log{"VT_SETMODE process 10 12", "KDSETMODE graphics", "TCFLSH", "KDSKBMODE off", "TCFLSH",
                          "KDSKBMODE xlate", "KDSETMODE text", "VT_SETMODE auto 0 0"}));
}

TEST(VtLock, AnotherVtIsBroughtOnScreenAndTheOldOneBack) {
    FakeVtState s;
    s.active = 2;  // the lock is for VT 7, VT 2 is on screen
    {
        gl::VtLock lock(fake(s, 7), {});
        EXPECT_EQ(s.active, 7);
        EXPECT_EQ(s.log.front(), "VT_ACTIVATE 7");
    }
    EXPECT_EQ(s.active, 2);
    EXPECT_EQ(s.log.back(), "VT_ACTIVATE 2");
}

TEST(VtLock, WithoutActivateTheScreenStays) {
    FakeVtState s;
    s.active = 2;
    { gl::VtLock lock(fake(s, 7), {.lock_switch = false, .activate = false}); }
    EXPECT_EQ(s.active, 2);
    for (const std::string& line : s.log) EXPECT_EQ(line.find("VT_ACTIVATE"), std::string::npos) << line;
}

// Each step failing in turn: what was done before it is undone, newest first, and the error is
// one line naming the device and the request.
TEST(VtLock, AStepFailingUndoesTheStepsBefore) {
    struct Case {
        unsigned long request;
        int error;
        std::string message;
        Log log;
    };
    const std::vector<Case> cases = {
        {VT_SETMODE, EPERM,
         "/dev/tty1: VT_SETMODE: Operation not permitted (the VT must be the process's controlling terminal, the "
         "unit's TTYPath= with StandardInput=tty, or the process needs CAP_SYS_TTY_CONFIG)",
         {"VT_SETMODE failed"}},
        {VT_LOCKSWITCH, EPERM,
         "/dev/tty1: VT_LOCKSWITCH: Operation not permitted (needs CAP_SYS_TTY_CONFIG; or set display.vt_lock_switch = false)",
         {"VT_SETMODE process 10 12", "VT_LOCKSWITCH failed", "VT_SETMODE auto 0 0"}},
        {KDSETMODE, ENOTTY,
         "/dev/tty1: KDSETMODE: Inappropriate ioctl for device (not a virtual terminal, or one without this ioctl)",
         {"VT_SETMODE process 10 12", "VT_LOCKSWITCH", "KDSETMODE failed", "VT_UNLOCKSWITCH", "VT_SETMODE auto 0 0"}},
        {KDSKBMODE, EPERM, "", {"VT_SETMODE process 10 12", "VT_LOCKSWITCH", "KDSETMODE graphics", "TCFLSH",
                                "KDSKBMODE failed", "KDSETMODE text", "VT_UNLOCKSWITCH", "VT_SETMODE auto 0 0"}},
    };
    for (const Case& c : cases) {
        FakeVtState s;
        s.fail[c.request] = c.error;
        try {
            gl::VtLock lock(fake(s), {.lock_switch = true, .activate = true});
            ADD_FAILURE() << "no error for request " << c.request;
        } catch (const RuntimeError& e) {
            if (!c.message.empty()) {
                EXPECT_EQ(std::string(e.what()), c.message);
            }
            EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
        }
        EXPECT_EQ(s.log, c.log);
        EXPECT_EQ(s.kd, KD_TEXT);
        EXPECT_EQ(s.kb, K_UNICODE);
        EXPECT_EQ(s.mode.mode, VT_AUTO);
        EXPECT_FALSE(s.switch_locked);
        // The failed lock left nothing live: a new one may be taken.
        s.fail.clear();
        EXPECT_NO_THROW(gl::VtLock(fake(s), {}));
    }
}

TEST(VtLock, AQueryFailingIsOneLineAndTouchesNothing) {
    FakeVtState s;
    s.fail[KDGETMODE] = ENOTTY;
    EXPECT_THROW(
        {
            try {
                gl::VtLock lock(fake(s), {});
            } catch (const RuntimeError& e) {
                EXPECT_STREQ(e.what(), "/dev/tty1: KDGETMODE: Inappropriate ioctl for device (not a virtual terminal, "
                                       "or one without this ioctl)");
                throw;
            }
        },
        RuntimeError);
    EXPECT_EQ(s.log, (Log{"KDGETMODE failed"}));
}

TEST(VtLock, OneLockAtATime) {
    FakeVtState a, b;
    gl::VtLock first(fake(a), {});
    EXPECT_THROW(gl::VtLock(fake(b, 2), {}), RuntimeError);
    EXPECT_TRUE(b.log.empty());
    EXPECT_EQ(a.kd, KD_GRAPHICS);  // the first is untouched
}

TEST(VtLock, RestoreNowIsIdempotentAndTheDestructorHasNothingLeft) {
    FakeVtState s;
    {
        gl::VtLock lock(fake(s), {});
        s.log.clear();
        gl::VtLock::restore_now();
        EXPECT_EQ(s.kd, KD_TEXT);
        EXPECT_EQ(s.log, (Log{"TCFLSH", "KDSKBMODE unicode", "KDSETMODE text", "VT_SETMODE auto 0 0"}));
        gl::VtLock::restore_now();
        EXPECT_EQ(s.log.size(), 4u);
    }
    EXPECT_EQ(s.log.size(), 4u);
    gl::VtLock::restore_now();  // no lock live: nothing
    EXPECT_EQ(s.log.size(), 4u);
}

// The kernel asks a VT_PROCESS owner with relsig before switching away, with acqsig after a
// switch back: away is refused, back is acknowledged.
TEST(VtLock, SwitchRequestsAreRefused) {
    FakeVtState s;
    gl::VtLock lock(fake(s), {});
    s.log.clear();
    raise(SIGUSR1);
    raise(SIGUSR2);
    EXPECT_EQ(s.log, (Log{"VT_RELDISP refuse", "VT_RELDISP ackacq"}));
}

// Release mode: the kernel's request away only sets a flag; the frame loop gives up the card and
// keyboards, then lets the switch go (VT_RELDISP 1); back on screen is acknowledged at once and
// reported once.
TEST(VtLock, InReleaseModeASwitchAwayWaitsForTheCallerAndBackIsReportedOnce) {
    FakeVtState s;
    gl::VtLock lock(fake(s), {.lock_switch = false, .activate = true, .release_on_switch = true});
    EXPECT_NE(lock.describe().find("switches let go with the card and keyboards"), std::string::npos);
    s.log.clear();
    EXPECT_EQ(lock.take_switch_request(), gl::VtSwitchRequest::None);
    raise(SIGUSR1);
    EXPECT_TRUE(s.log.empty());  // not answered from the handler
    EXPECT_EQ(lock.take_switch_request(), gl::VtSwitchRequest::Away);
    EXPECT_EQ(lock.take_switch_request(), gl::VtSwitchRequest::Away);  // until answered
    lock.allow_switch_away();
    EXPECT_EQ(s.log, (Log{"VT_RELDISP allow"}));
    EXPECT_EQ(lock.take_switch_request(), gl::VtSwitchRequest::None);
    lock.allow_switch_away();  // nothing pending: nothing sent
    EXPECT_EQ(s.log.size(), 1u);
    raise(SIGUSR2);
    EXPECT_EQ(s.log, (Log{"VT_RELDISP allow", "VT_RELDISP ackacq"}));
    EXPECT_EQ(lock.take_switch_request(), gl::VtSwitchRequest::Back);
    EXPECT_EQ(lock.take_switch_request(), gl::VtSwitchRequest::None);
    // A request the caller cannot honour is refused.
    raise(SIGUSR1);
    lock.refuse_switch_away();
    EXPECT_EQ(s.log.back(), "VT_RELDISP refuse");
}

// A return the kernel was told of at once, then a new switch away before the frame loop looked
// (`chvt 1; chvt 2`): the Back is stale and dropped with the Away, or the kiosk would take the
// screen from the other VT; on_screen() says which VT is showing.
TEST(VtLock, AStaleReturnIsDroppedWhenASwitchAwayFollows) {
    FakeVtState s;
    gl::VtLock lock(fake(s), {.lock_switch = false, .activate = true, .release_on_switch = true});
    EXPECT_TRUE(lock.on_screen());
    raise(SIGUSR1);
    EXPECT_EQ(lock.take_switch_request(), gl::VtSwitchRequest::Away);
    lock.allow_switch_away();
    s.active = 2;
    EXPECT_FALSE(lock.on_screen());
    raise(SIGUSR2);  // back (acknowledged by the handler) ...
    raise(SIGUSR1);  // ... and away again before the frame loop looked
    EXPECT_EQ(lock.take_switch_request(), gl::VtSwitchRequest::Away);
    lock.allow_switch_away();
    EXPECT_EQ(lock.take_switch_request(), gl::VtSwitchRequest::None);
}

// A switch away still unanswered when the lock ends is let go (the process gives up the screen),
// before the VT's modes are restored.
TEST(VtLock, APendingSwitchAwayIsLetGoWhenTheLockEnds) {
    FakeVtState s;
    {
        gl::VtLock lock(fake(s), {.lock_switch = false, .activate = true, .release_on_switch = true});
        s.log.clear();
        raise(SIGUSR1);
    }
    ASSERT_FALSE(s.log.empty());
    EXPECT_EQ(s.log.front(), "VT_RELDISP allow");
    EXPECT_EQ(s.kd, KD_TEXT);
}

TEST(VtLock, ReleaseAndTheKernelsSwitchLockExcludeEachOther) {
    FakeVtState s;
    try {
        gl::VtLock lock(fake(s), {.lock_switch = true, .activate = true, .release_on_switch = true});
        FAIL() << "no error";
    } catch (const InputError& e) {
        EXPECT_EQ(std::string(e.what()), "/dev/tty1: a VT switch cannot be both let go (display.vt_switch = release) and "
                                         "locked (display.vt_lock_switch)");
    }
    EXPECT_TRUE(s.log.empty());
    // In refuse mode take_switch_request never reports anything: the handler answered.
    gl::VtLock lock(fake(s), {});
    raise(SIGUSR1);
    EXPECT_EQ(lock.take_switch_request(), gl::VtSwitchRequest::None);
    EXPECT_EQ(s.log.back(), "VT_RELDISP refuse");
}

TEST(VtLock, TheSwitchSignalsAreGivenBack) {
    struct sigaction before {};
    sigaction(SIGUSR1, nullptr, &before);
    FakeVtState s;
    { gl::VtLock lock(fake(s), {}); }
    struct sigaction after {};
    sigaction(SIGUSR1, nullptr, &after);
    EXPECT_EQ(before.sa_handler, after.sa_handler);
}

// A crash restores the VT before the process dies with the signal it got.
TEST(VtLockDeathTest, ACrashRestoresTheVt) {
    // The default ("fast") style forks: the child writes its log into this pipe.
    int pipe_fds[2];
    ASSERT_EQ(pipe(pipe_fds), 0);
    const int write_end = pipe_fds[1];
    EXPECT_EXIT(
        {
            FakeVtState s;
            s.log_fd = write_end;
            gl::VtLock lock(fake(s), {});
            abort();
        },
        testing::KilledBySignal(SIGABRT), "");
    close(write_end);
    std::string text;
    char buffer[512];
    for (ssize_t n; (n = read(pipe_fds[0], buffer, sizeof buffer)) > 0;) text.append(buffer, std::size_t(n));
    close(pipe_fds[0]);
    EXPECT_EQ(text, "VT_SETMODE process 10 12\nKDSETMODE graphics\nTCFLSH\nKDSKBMODE off\n"
                    "TCFLSH\nKDSKBMODE unicode\nKDSETMODE text\nVT_SETMODE auto 0 0\n");
}

// The real device: a pseudo-terminal is refused with one line naming it.
TEST(VtDevice, APseudoTerminalIsNotAVt) {
    int master = -1, slave = -1;
    char name[128];
    ASSERT_EQ(openpty(&master, &slave, name, nullptr, nullptr), 0);
    try {
        gl::open_vt_device(name);
        ADD_FAILURE() << "a pty was taken for a VT";
    } catch (const RuntimeError& e) {
        EXPECT_EQ(std::string(e.what()), std::string(name) + ": not a virtual terminal (a VT is /dev/tty1 .. /dev/tty63)");
    }
    close(master);
    close(slave);
}

TEST(VtDevice, AMissingDeviceIsNamed) {
    try {
        gl::open_vt_device("/nonexistent/tty9");
        ADD_FAILURE();
    } catch (const RuntimeError& e) {
        EXPECT_STREQ(e.what(), "/nonexistent/tty9: cannot open: No such file or directory");
    }
}

}  // namespace
}  // namespace glint::test
