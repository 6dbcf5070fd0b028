// The VT lock on a real virtual terminal of this machine's kernel. The VT used is a free one
// (VT_OPENQRY), never the one on screen: it is allocated, locked, read back through a second
// descriptor, restored, read back again and deallocated. VT_LOCKSWITCH is global for the few
// milliseconds the lock lives; the crash handler restores it if the test dies half-way.
#include <fcntl.h>
#include <linux/kd.h>
#include <linux/vt.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/sysmacros.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <functional>
#include <string>

#include "appliance/gl/vt_lock.hpp"

namespace glint::test {
namespace {

namespace fs = std::filesystem;

struct Modes {
    int kd = -1, kb = -1, mode = -1;
};

Modes read_modes(const std::string& path) {
    Modes m;
    const int fd = open(path.c_str(), O_RDONLY | O_NOCTTY | O_CLOEXEC);
    EXPECT_GE(fd, 0) << path;
    vt_mode mode{};
    EXPECT_EQ(ioctl(fd, KDGETMODE, &m.kd), 0);
    EXPECT_EQ(ioctl(fd, KDGKBMODE, &m.kb), 0);
    EXPECT_EQ(ioctl(fd, VT_GETMODE, &mode), 0);
    m.mode = mode.mode;
    close(fd);
    return m;
}

int active_vt(int tty0) {
    vt_stat state{};
    EXPECT_EQ(ioctl(tty0, VT_GETSTATE, &state), 0);
    return state.v_active;
}

// A free VT of the running kernel (VT_OPENQRY, never the one on screen) with a device node of the
// test's own (the container or machine may have no /dev/ttyN for it: major 4, minor N), given back
// at the end (VT_DISALLOCATE) so that nothing of the test stays allocated.
class FreeVt : public ::testing::Test {
protected:
    void SetUp() override {
        tty0_ = open("/dev/tty0", O_RDWR | O_NOCTTY | O_CLOEXEC);
        ASSERT_GE(tty0_, 0) << "/dev/tty0: " << std::strerror(errno);
        ASSERT_EQ(ioctl(tty0_, VT_OPENQRY, &n_), 0);
        ASSERT_GT(n_, 0);
        on_screen_ = active_vt(tty0_);
        ASSERT_NE(n_, on_screen_);
        dir_ = fs::temp_directory_path() / ("glint-vt-" + std::to_string(getpid()));
        fs::create_directories(dir_);
        node_ = (dir_ / ("tty" + std::to_string(n_))).string();
        ASSERT_EQ(mknod(node_.c_str(), S_IFCHR | 0600, makedev(4, unsigned(n_))), 0) << node_ << ": " << std::strerror(errno);
    }
    void TearDown() override {
        if (tty0_ < 0) return;
        // The kernel lets go of a closed tty in a work queue, and refuses (EBUSY) until it has:
        // asked again for up to a second.
        int r = -1;
        for (int k = 0; k < 100 && (r = ioctl(tty0_, VT_DISALLOCATE, n_)) != 0 && errno == EBUSY; ++k) usleep(10'000);
        EXPECT_EQ(r, 0) << "VT_DISALLOCATE " << n_ << ": " << std::strerror(errno);
        close(tty0_);
        fs::remove_all(dir_);
    }
    // Whether `done` holds within 2 s.
    static bool wait_for(const std::function<bool()>& done) {
        for (int k = 0; k < 200; ++k) {
            if (done()) return true;
            usleep(10'000);
        }
        return false;
    }
    int tty0_ = -1, n_ = 0, on_screen_ = 0;
    fs::path dir_;
    std::string node_;
};

TEST_F(FreeVt, IsLockedAndRestored) {
    const Modes before = read_modes(node_);
    EXPECT_EQ(before.kd, KD_TEXT);
    EXPECT_EQ(before.mode, VT_AUTO);
    {
        gl::VtLock lock(gl::open_vt_device(node_), {.lock_switch = true, .activate = false});
        const Modes locked = read_modes(node_);
        EXPECT_EQ(locked.kd, KD_GRAPHICS);
        EXPECT_EQ(locked.kb, K_OFF);
        EXPECT_EQ(locked.mode, VT_PROCESS);
        EXPECT_EQ(lock.describe(), node_ + " (VT " + std::to_string(n_) +
                                       "): graphics mode, keyboard off, switches refused (VT_PROCESS, VT_LOCKSWITCH)");
    }
    const Modes after = read_modes(node_);
    EXPECT_EQ(after.kd, before.kd);
    EXPECT_EQ(after.kb, before.kb);
    EXPECT_EQ(after.mode, before.mode);
    EXPECT_EQ(active_vt(tty0_), on_screen_);
}

// Release mode against the kernel: the free VT is brought on screen and locked; a switch to the VT
// that was on screen is asked for (as `chvt` would); the kernel waits for the kiosk's answer, the
// switch completes only after allow_switch_away(), and the switch back is reported. The lock's end
// puts the earlier VT on screen again. The screen changes for a few milliseconds.
TEST_F(FreeVt, InReleaseModeTheKernelWaitsForTheAnswerAndReportsTheReturn) {
    {
        gl::VtLock lock(gl::open_vt_device(node_), {.lock_switch = false, .activate = true, .release_on_switch = true});
        ASSERT_EQ(active_vt(tty0_), n_);
        ASSERT_EQ(ioctl(tty0_, VT_ACTIVATE, on_screen_), 0);
        EXPECT_TRUE(wait_for([&] { return lock.take_switch_request() == gl::VtSwitchRequest::Away; }));
        usleep(50'000);
        EXPECT_EQ(active_vt(tty0_), n_) << "the kernel switched before the kiosk answered";
        lock.allow_switch_away();
        EXPECT_TRUE(wait_for([&] { return active_vt(tty0_) == on_screen_; }));
        EXPECT_EQ(lock.take_switch_request(), gl::VtSwitchRequest::None);
        ASSERT_EQ(ioctl(tty0_, VT_ACTIVATE, n_), 0);
        EXPECT_TRUE(wait_for([&] { return lock.take_switch_request() == gl::VtSwitchRequest::Back; }));
        EXPECT_EQ(active_vt(tty0_), n_);
        EXPECT_EQ(read_modes(node_).kd, KD_GRAPHICS);
    }
    EXPECT_TRUE(wait_for([&] { return active_vt(tty0_) == on_screen_; }));
    EXPECT_EQ(read_modes(node_).kd, KD_TEXT);
    EXPECT_EQ(read_modes(node_).mode, VT_AUTO);
}

TEST(RealVt, AutoFindsTheVtOnScreenWithoutTouchingIt) {
    // ctest's standard input is not a VT: auto asks /dev/tty0 which VT is on screen. Only opened.
    const int tty0 = open("/dev/tty0", O_RDONLY | O_NOCTTY | O_CLOEXEC);
    ASSERT_GE(tty0, 0);
    const int on_screen = active_vt(tty0);
    close(tty0);
    const std::string path = "/dev/tty" + std::to_string(on_screen);
    if (!fs::exists(path)) {
        // Without the node auto names it in its error.
        EXPECT_THROW(gl::open_vt_device("auto"), std::exception);
        return;
    }
    const auto device = gl::open_vt_device("auto");
    EXPECT_EQ(device->path(), path);
    EXPECT_EQ(device->number(), on_screen);
}

}  // namespace
}  // namespace glint::test
