// A simulated virtual terminal behind gl::VtDevice: it keeps the modes the kernel would keep, logs
// every ioctl in order ("KDSETMODE graphics"), and fails a chosen request with a chosen errno, so
// the tests check the VT lock's sequence, its restore order and its errors without a console.
#pragma once

#include <linux/kd.h>
#include <linux/vt.h>
#include <termios.h>
#include <unistd.h>
#include <sys/ioctl.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "appliance/gl/vt_lock.hpp"

namespace glint::test {

struct FakeVtState {
    int active = 1;
    int kd = KD_TEXT;
    int kb = K_UNICODE;
    vt_mode mode{};  // VT_AUTO
    bool switch_locked = false;
    std::vector<std::string> log;
    std::map<unsigned long, int> fail;  // request -> errno
    int log_fd = -1;                    // also write() each line here (a death test's child)
};

class FakeVt final : public gl::VtDevice {
public:
    FakeVt(FakeVtState& state, int number, std::string path = "/dev/tty1")
        : state_(state), number_(number), path_(std::move(path)) {}
    const std::string& path() const override { return path_; }
    int number() const override { return number_; }
    int ioctl(unsigned long request, unsigned long arg) noexcept override {
        char line[64];
        const char* name = "?";
        std::string detail;
        switch (request) {
            case VT_GETSTATE: name = "VT_GETSTATE"; break;
            case KDGETMODE: name = "KDGETMODE"; break;
            case KDGKBMODE: name = "KDGKBMODE"; break;
            case VT_GETMODE: name = "VT_GETMODE"; break;
            case VT_ACTIVATE: name = "VT_ACTIVATE"; break;
            case VT_SETMODE: name = "VT_SETMODE"; break;
            case VT_LOCKSWITCH: name = "VT_LOCKSWITCH"; break;
            case VT_UNLOCKSWITCH: name = "VT_UNLOCKSWITCH"; break;
            case KDSETMODE: name = "KDSETMODE"; break;
            case KDSKBMODE: name = "KDSKBMODE"; break;
            case TCFLSH: name = "TCFLSH"; break;
            case VT_RELDISP: name = "VT_RELDISP"; break;
        }
        if (auto f = state_.fail.find(request); f != state_.fail.end()) {
            std::snprintf(line, sizeof line, "%s failed", name);
            record(line);
            errno = f->second;
            return -1;
        }
        switch (request) {
            case VT_GETSTATE: reinterpret_cast<vt_stat*>(arg)->v_active = static_cast<unsigned short>(state_.active); return 0;
            case KDGETMODE: *reinterpret_cast<int*>(arg) = state_.kd; return 0;
            case KDGKBMODE: *reinterpret_cast<int*>(arg) = state_.kb; return 0;
            case VT_GETMODE: *reinterpret_cast<vt_mode*>(arg) = state_.mode; return 0;
            case VT_ACTIVATE: state_.active = int(arg); std::snprintf(line, sizeof line, "VT_ACTIVATE %lu", arg); break;
            case VT_SETMODE:
                state_.mode = *reinterpret_cast<const vt_mode*>(arg);
                std::snprintf(line, sizeof line, "VT_SETMODE %s %d %d", state_.mode.mode == VT_PROCESS ? "process" : "auto",
                              state_.mode.relsig, state_.mode.acqsig);
                break;
            case VT_LOCKSWITCH: state_.switch_locked = true; std::snprintf(line, sizeof line, "VT_LOCKSWITCH"); break;
            case VT_UNLOCKSWITCH: state_.switch_locked = false; std::snprintf(line, sizeof line, "VT_UNLOCKSWITCH"); break;
            case KDSETMODE:
                state_.kd = int(arg);
                std::snprintf(line, sizeof line, "KDSETMODE %s", arg == KD_GRAPHICS ? "graphics" : arg == KD_TEXT ? "text" : "?");
                break;
            case KDSKBMODE:
                state_.kb = int(arg);
                std::snprintf(line, sizeof line, "KDSKBMODE %s",
                              arg == K_OFF ? "off" : arg == K_UNICODE ? "unicode" : arg == K_XLATE ? "xlate" : "?");
                break;
            case TCFLSH: std::snprintf(line, sizeof line, "TCFLSH"); break;
            case VT_RELDISP:
                std::snprintf(line, sizeof line, "VT_RELDISP %s", arg == 0 ? "refuse" : arg == 1 ? "allow" : arg == VT_ACKACQ ? "ackacq" : "?");
                break;
            default: errno = ENOTTY; return -1;
        }
        record(line);
        return 0;
    }

private:
    void record(const char* line) noexcept {
        if (state_.log_fd >= 0) {
            // write() only: this may run in a crash handler in a death test's child.
            (void)!::write(state_.log_fd, line, std::strlen(line));
            (void)!::write(state_.log_fd, "\n", 1);
            return;
        }
        state_.log.emplace_back(line);
    }

    FakeVtState& state_;
    int number_;
    std::string path_;
};

}  // namespace glint::test
