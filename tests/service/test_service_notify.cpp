// sd_notify as the kiosk sends it (appliance/ui/service_notify.hpp): the test plays systemd,
// binding the datagram socket NOTIFY_SOCKET names and reading what arrives.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdlib>
#include <optional>
#include <string>

#include "appliance/ui/service_notify.hpp"
#include "tests/service/fake_systemd.hpp"

using namespace glint::ui;
using namespace std::chrono_literals;

using glint::test::FakeSystemd;

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

// What issue 18 asks of a stalled frame loop, on a simulated clock: READY, pings while frames
// come, none while the loop is stuck, and pings again once it runs.
TEST(ServiceNotify, AStalledLoopStopsThePings) {
    FakeSystemd systemd;
    ServiceNotifier notifier;
    WatchdogFeeder feeder(notifier, 2s);
    notifier.ready("ATTRACT");
    std::int64_t t = 0;
    const auto frames = [&](double seconds) {
        int pings = 0;
        for (const std::int64_t end = t + static_cast<std::int64_t>(seconds * 1e9); t < end; t += 33'333'333)
            pings += feeder.tick(t);
        return pings;
    };
    EXPECT_EQ(frames(2.5), 3);        // at 0, 1 and 2 s
    t += 10'000'000'000;              // one frame that takes 10 s: no tick, no ping
    EXPECT_EQ(frames(0.1), 1);        // the loop is back: at once
    EXPECT_EQ(systemd.receive(), "READY=1\nSTATUS=ATTRACT");
    for (int k = 0; k < 4; ++k) EXPECT_EQ(systemd.receive(), "WATCHDOG=1") << k;
    EXPECT_EQ(systemd.receive(), std::nullopt);
}
