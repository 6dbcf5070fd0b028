// A signal that ends a command at once (app/interrupt.cpp: no StopRequest alive, so _Exit with
// 128 + the signal, no destructor run) restores a locked VT first.
#include <signal.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <string>

#include "appliance/app/interrupt.hpp"
#include "appliance/gl/vt_lock.hpp"
#include "tests/lockdown/fake_vt.hpp"

namespace glint::test {
namespace {

TEST(InterruptDeathTest, SigtermWithoutAStopRequestRestoresTheVtBeforeExiting) {
    int pipe_fds[2];
    ASSERT_EQ(pipe(pipe_fds), 0);
    const int write_end = pipe_fds[1];
    EXPECT_EXIT(
        {
            app::install_interrupt_handling();
            FakeVtState s;
            s.log_fd = write_end;
            gl::VtLock lock(std::make_unique<FakeVt>(s, 1), {});
            kill(getpid(), SIGTERM);
            for (;;) pause();  // the signal thread ends the process
        },
        testing::ExitedWithCode(128 + SIGTERM), "glint: stopped by Terminated");
    close(write_end);
    std::string text;
    char buffer[512];
    for (ssize_t n; (n = read(pipe_fds[0], buffer, sizeof buffer)) > 0;) text.append(buffer, std::size_t(n));
    close(pipe_fds[0]);
    EXPECT_EQ(text, "VT_SETMODE process 10 12\nKDSETMODE graphics\nTCFLSH\nKDSKBMODE off\n"
                    "TCFLSH\nKDSKBMODE unicode\nKDSETMODE text\nVT_SETMODE auto 0 0\n");
}

}  // namespace
}  // namespace glint::test
