// Host HAL implementations: see sim_hal.hpp.
#include "firmware_bridge/firmware/sim/sim_hal.hpp"
#include "firmware_bridge/host/serial_speed.hpp"  // header only: the termios constants

#include <fcntl.h>
#include <poll.h>
#include <pty.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <ctime>
#include <stdexcept>
#include <system_error>

namespace glint::firmware::sim {
namespace {

std::uint64_t monotonic_ns() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000u + static_cast<std::uint64_t>(ts.tv_nsec);
}

[[noreturn]] void throw_errno(const std::string& what) {
    throw std::system_error(errno, std::generic_category(), what);
}

}  // namespace

// ---- RealtimeClock ----

RealtimeClock::RealtimeClock(int wake_fd) : start_ns_(monotonic_ns()), wake_fd_(wake_fd) {}

std::uint64_t RealtimeClock::now_us() { return (monotonic_ns() - start_ns_) / 1000; }

void RealtimeClock::wait_until_us(std::uint64_t deadline_us) {
    const std::uint64_t now = now_us();
    if (deadline_us <= now) return;
    const std::uint64_t wait_us = deadline_us - now;
    timespec timeout{static_cast<time_t>(wait_us / 1'000'000), static_cast<long>((wait_us % 1'000'000) * 1000)};
    if (wake_fd_ >= 0) {
        pollfd p{wake_fd_, POLLIN, 0};
        ppoll(&p, 1, &timeout, nullptr);  // early wake-up on input; EINTR is fine too
    } else {
        nanosleep(&timeout, nullptr);
    }
}

// ---- MemoryUart ----

bool MemoryUart::write(std::span<const std::uint8_t> bytes) {
    if (sent.size() + bytes.size() > capacity_) return false;
    sent.insert(sent.end(), bytes.begin(), bytes.end());
    return true;
}

std::size_t MemoryUart::read(std::span<std::uint8_t> out) {
    std::size_t n = 0;
    while (n < out.size() && !rx_.empty()) {
        out[n++] = rx_.front();
        rx_.pop_front();
    }
    return n;
}

std::vector<std::uint8_t> MemoryUart::take() {
    std::vector<std::uint8_t> out;
    out.swap(sent);
    return out;
}

// ---- PtyUart ----

PtyUart::PtyUart(std::string link_path, std::size_t tx_buffer_bytes) : FdUart(tx_buffer_bytes) {
    int& master_ = fd_;
    std::array<char, 256> name{};
    if (openpty(&master_, &slave_, name.data(), nullptr, nullptr) != 0) throw_errno("openpty");
    slave_path_ = name.data();
    // Raw slave: no echo, no line editing, no CR/LF translation; binary frames pass unchanged.
    termios tio{};
    if (tcgetattr(slave_, &tio) == 0) {
        cfmakeraw(&tio);
        tcsetattr(slave_, TCSANOW, &tio);
    }
    const int flags = fcntl(master_, F_GETFL);
    if (flags < 0 || fcntl(master_, F_SETFL, flags | O_NONBLOCK) != 0) {
        const int e = errno;
        close(master_);
        close(slave_);
        errno = e;
        throw_errno("fcntl(O_NONBLOCK) on the pty master");
    }
    fcntl(master_, F_SETFD, FD_CLOEXEC);
    fcntl(slave_, F_SETFD, FD_CLOEXEC);
    if (!link_path.empty()) {
        struct stat st {};
        if (lstat(link_path.c_str(), &st) == 0) {
            if (!S_ISLNK(st.st_mode)) {
                close(master_);
                close(slave_);
                throw std::runtime_error(link_path + ": exists and is not a symlink; not replacing it");
            }
            unlink(link_path.c_str());
        }
        if (symlink(slave_path_.c_str(), link_path.c_str()) != 0) {
            const int e = errno;
            close(master_);
            close(slave_);
            errno = e;
            throw_errno(link_path + ": cannot create symlink to " + slave_path_);
        }
        link_path_ = link_path;
    }
}

PtyUart::~PtyUart() {
    if (!link_path_.empty()) unlink(link_path_.c_str());
    close(fd_);
    close(slave_);
}

SerialDeviceUart::SerialDeviceUart(std::string path, int baud, std::size_t tx_buffer_bytes)
    : FdUart(tx_buffer_bytes), path_(std::move(path)) {
    if (host::termios_speed(baud) == B0) throw std::runtime_error("baud rate " + std::to_string(baud) + " is not supported");
    fd_ = ::open(path_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) throw_errno(path_ + ": cannot open");
    termios tio{};
    if (tcgetattr(fd_, &tio) != 0) {
        const int e = errno;
        close(fd_);
        errno = e;
        throw_errno(path_ + ": not a serial device");
    }
    cfmakeraw(&tio);
    tio.c_cflag |= CLOCAL | CREAD;
    cfsetispeed(&tio, host::termios_speed(baud));
    cfsetospeed(&tio, host::termios_speed(baud));
    if (tcsetattr(fd_, TCSANOW, &tio) != 0) {
        const int e = errno;
        close(fd_);
        errno = e;
        throw_errno(path_ + ": cannot set raw mode at " + std::to_string(baud) + " baud");
    }
}

SerialDeviceUart::~SerialDeviceUart() { close(fd_); }

std::size_t FdUart::flush() {
    while (!tx_.empty()) {
        std::array<std::uint8_t, 4096> chunk{};
        std::size_t n = 0;
        for (auto it = tx_.begin(); it != tx_.end() && n < chunk.size(); ++it) chunk[n++] = *it;
        const ssize_t w = ::write(fd_, chunk.data(), n);
        if (w <= 0) break;  // EAGAIN: the pty's buffer is full (nobody reading)
        tx_.erase(tx_.begin(), tx_.begin() + w);
    }
    return tx_.size();
}

bool FdUart::write(std::span<const std::uint8_t> bytes) {
    flush();
    if (tx_.size() + bytes.size() > tx_capacity_) return false;
    tx_.insert(tx_.end(), bytes.begin(), bytes.end());
    flush();
    return true;
}

std::size_t FdUart::read(std::span<std::uint8_t> out) {
    const ssize_t n = ::read(fd_, out.data(), out.size());
    return n > 0 ? static_cast<std::size_t>(n) : 0;  // EAGAIN: nothing; EIO: no client
}

bool FdUart::wait_drain(int timeout_ms) {
    const std::size_t before = flush();
    if (before == 0) return true;
    pollfd p{fd_, POLLOUT, 0};
    poll(&p, 1, timeout_ms);
    return flush() < before;
}

// ---- SimGpio ----

bool SimGpio::button_pressed(std::uint8_t id) {
    const std::uint64_t t = clock_.now_us();
    for (const ButtonPress& p : presses_) {
        if (p.button != id || t < p.start_us || t >= p.end_us + p.bounce_us) continue;
        // Bounce: for bounce_us after each edge the contact toggles every millisecond.
        const bool after_release = t >= p.end_us;
        const std::uint64_t since_edge = after_release ? t - p.end_us : t - p.start_us;
        const bool settled_level = !after_release;
        if (since_edge < p.bounce_us) return ((since_edge / 1000) % 2 == 0) == settled_level;
        return settled_level;
    }
    return false;
}

void SimGpio::set_lamp(bool on) {
    if (on != lamp_) ++lamp_changes_;
    lamp_ = on;
}

}  // namespace glint::firmware::sim
