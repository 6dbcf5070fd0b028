// sd_notify as the kiosk sends it (appliance/ui/service_notify.hpp): the test plays systemd,
// binding the datagram socket NOTIFY_SOCKET names and reading what arrives.
#include <gtest/gtest.h>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

#include "appliance/ui/service_notify.hpp"

namespace fs = std::filesystem;
using namespace glint::ui;
using namespace std::chrono_literals;

namespace {

// systemd's end of the notify socket: a bound AF_UNIX datagram socket, NOTIFY_SOCKET set to it
// for the test's life.
class FakeSystemd {
public:
    FakeSystemd() {
        char tmpl[] = "/tmp/glint-notify-XXXXXX";
        dir_ = ::mkdtemp(tmpl);
        path_ = dir_ / "notify";
        fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path_.c_str());
        EXPECT_EQ(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
        // A test that waits for a message that never comes fails instead of hanging.
        timeval timeout{0, 200'000};
        ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
        ::setenv("NOTIFY_SOCKET", path_.c_str(), 1);
    }
    ~FakeSystemd() {
        ::unsetenv("NOTIFY_SOCKET");
        ::close(fd_);
        fs::remove_all(dir_);
    }
    // The next datagram, or nullopt after 200 ms without one.
    std::optional<std::string> receive() {
        char buf[4096];
        const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
        if (n < 0) return std::nullopt;
        return std::string(buf, static_cast<std::size_t>(n));
    }

private:
    fs::path dir_, path_;
    int fd_ = -1;
};

}  // namespace

TEST(ServiceNotify, SendsWhatTheKioskSendsInOrder) {
    FakeSystemd systemd;
    ServiceNotifier notifier;
    ASSERT_TRUE(notifier.enabled());
    // Start-up, the first frame on screen, a state change, the frame loop's pings, SIGHUP, SIGTERM.
    EXPECT_TRUE(notifier.status("starting: opening the display"));
    EXPECT_TRUE(notifier.ready("ATTRACT"));
    EXPECT_TRUE(notifier.status("CAPTURE"));
    EXPECT_TRUE(notifier.watchdog());
    EXPECT_TRUE(notifier.reloading());
    EXPECT_TRUE(notifier.ready());
    EXPECT_TRUE(notifier.stopping("stopping: SIGTERM"));
    EXPECT_EQ(systemd.receive(), "STATUS=starting: opening the display");
    EXPECT_EQ(systemd.receive(), "READY=1\nSTATUS=ATTRACT");
    EXPECT_EQ(systemd.receive(), "STATUS=CAPTURE");
    EXPECT_EQ(systemd.receive(), "WATCHDOG=1");
    EXPECT_EQ(systemd.receive(), "RELOADING=1");
    EXPECT_EQ(systemd.receive(), "READY=1");
    EXPECT_EQ(systemd.receive(), "STOPPING=1\nSTATUS=stopping: SIGTERM");
    EXPECT_EQ(systemd.receive(), std::nullopt);
}

TEST(ServiceNotify, AStatusCannotCarryOtherAssignments) {
    FakeSystemd systemd;
    ServiceNotifier notifier;
    EXPECT_TRUE(notifier.status("camera lost\nREADY=1\rMAINPID=1"));
    EXPECT_EQ(systemd.receive(), "STATUS=camera lost READY=1 MAINPID=1");
}

TEST(ServiceNotify, DoesNothingWithoutNotifySocket) {
    ::unsetenv("NOTIFY_SOCKET");
    ServiceNotifier notifier;
    EXPECT_FALSE(notifier.enabled());
    EXPECT_FALSE(notifier.ready("ATTRACT"));
    EXPECT_FALSE(notifier.watchdog());
    EXPECT_FALSE(notifier.stopping());
    EXPECT_EQ(notifier.last_error(), "");
}

TEST(ServiceNotify, ReportsASocketThatIsGone) {
    ::setenv("NOTIFY_SOCKET", "/nonexistent/glint-notify", 1);
    ServiceNotifier notifier;
    EXPECT_TRUE(notifier.enabled());
    EXPECT_FALSE(notifier.watchdog());
    EXPECT_EQ(notifier.last_error(), "sd_notify: No such file or directory");
    ::unsetenv("NOTIFY_SOCKET");
}

TEST(ServiceNotify, WatchdogIntervalFromTheEnvironment) {
    ::unsetenv("WATCHDOG_USEC");
    ::unsetenv("WATCHDOG_PID");
    EXPECT_EQ(watchdog_interval(), std::nullopt);
    ::setenv("WATCHDOG_USEC", "20000000", 1);
    EXPECT_EQ(watchdog_interval(), std::chrono::microseconds(20'000'000));
    ::setenv("WATCHDOG_PID", std::to_string(::getpid()).c_str(), 1);
    EXPECT_EQ(watchdog_interval(), std::chrono::microseconds(20'000'000));
    // Meant for another process (a parent that kept its environment): not ours to feed.
    ::setenv("WATCHDOG_PID", std::to_string(::getpid() + 1).c_str(), 1);
    EXPECT_EQ(watchdog_interval(), std::nullopt);
    ::unsetenv("WATCHDOG_USEC");
    ::unsetenv("WATCHDOG_PID");
}

TEST(ServiceNotify, FeederPingsAtHalfTheInterval) {
    FakeSystemd systemd;
    ServiceNotifier notifier;
    WatchdogFeeder feeder(notifier, 2s);
    EXPECT_EQ(feeder.period_ns(), 1'000'000'000);
    // 30 Hz frames over 3.5 s: pings at 0, 1, 2 and 3 s (the frame at or after each second).
    int pings = 0;
    for (int frame = 0; frame <= 105; ++frame) pings += feeder.tick(frame * 33'333'333LL);
    EXPECT_EQ(pings, 4);
    for (int k = 0; k < 4; ++k) EXPECT_EQ(systemd.receive(), "WATCHDOG=1") << k;
    EXPECT_EQ(systemd.receive(), std::nullopt);
}

TEST(ServiceNotify, FeederWithoutWatchdogNeverPings) {
    FakeSystemd systemd;
    ServiceNotifier notifier;
    WatchdogFeeder feeder(notifier, std::nullopt);
    EXPECT_EQ(feeder.period_ns(), 0);
    EXPECT_FALSE(feeder.tick(0));
    EXPECT_FALSE(feeder.tick(5'000'000'000));
    EXPECT_EQ(systemd.receive(), std::nullopt);
}
