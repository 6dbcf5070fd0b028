// systemd's end of the sd_notify protocol for tests: a bound AF_UNIX datagram socket with
// NOTIFY_SOCKET set to it for the object's life, and what the process under test sent. Header
// only, for any test folder that checks what the kiosk tells systemd (READY, STATUS, WATCHDOG).
#pragma once

#include <sys/socket.h>
#include <sys/time.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>

namespace glint::test {

class FakeSystemd {
public:
    // `timeout_ms`: how long receive() waits before it gives nullopt, so a test that waits for a
    // message that never comes fails instead of hanging.
    explicit FakeSystemd(int timeout_ms = 200) {
        char tmpl[] = "/tmp/glint-notify-XXXXXX";
        if (!::mkdtemp(tmpl)) throw std::runtime_error("FakeSystemd: mkdtemp failed");
        dir_ = tmpl;
        path_ = dir_ / "notify";
        fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
        sockaddr_un addr{};
        addr.sun_family = AF_UNIX;
        std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path_.c_str());
        if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0)
            throw std::runtime_error("FakeSystemd: cannot bind " + path_.string());
        timeval timeout{timeout_ms / 1000, (timeout_ms % 1000) * 1000};
        ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
        ::setenv("NOTIFY_SOCKET", path_.c_str(), 1);
    }
    FakeSystemd(const FakeSystemd&) = delete;
    FakeSystemd& operator=(const FakeSystemd&) = delete;
    ~FakeSystemd() {
        ::unsetenv("NOTIFY_SOCKET");
        ::close(fd_);
        std::error_code ec;
        std::filesystem::remove_all(dir_, ec);
    }
    const std::filesystem::path& socket_path() const { return path_; }
    // The next datagram, or nullopt when none came within the timeout.
    std::optional<std::string> receive() {
        char buf[4096];
        const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
        if (n < 0) return std::nullopt;
        return std::string(buf, static_cast<std::size_t>(n));
    }

private:
    std::filesystem::path dir_, path_;
    int fd_ = -1;
};

}  // namespace glint::test
