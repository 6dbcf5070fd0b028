#include "firmware_bridge/host/serial_source.hpp"
#include "firmware_bridge/host/serial_speed.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/stat.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

namespace glint::host {

namespace {

std::string errno_text(int err) { return std::strerror(err); }

}  // namespace

bool serial_baud_supported(int baud) { return termios_speed(baud) != B0; }

SerialSource::SerialSource(std::string name, SerialOptions options, recording::Clock& clock,
                           SourceOptions source_options)
    : OrientationSource(std::move(name), clock, source_options), options_(std::move(options)) {
    if (options_.path.empty()) throw SourceError(this->name() + ": no serial device path");
    if (!serial_baud_supported(options_.baud))
        throw SourceError(this->name() + ": baud rate " + std::to_string(options_.baud) +
                          " is not a standard rate (e.g. 115200, 230400, 460800, 921600)");
}

SerialSource::~SerialSource() { stop(); }

void SerialSource::start() {
    if (thread_.joinable()) return;
    wake_fd_ = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
    if (wake_fd_ < 0) throw SourceError(name() + ": eventfd: " + errno_text(errno));
    stream_ = std::make_unique<BoardStream>([this](const OrientationSample& s) { publish(s); });
    stream_->set_recorder(recorder_);
    stream_->set_message_sink(message_sink_);
    stopping_ = false;
    set_state(LinkState::Connecting);
    thread_ = std::thread([this] { run(); });
}

void SerialSource::stop() {
    if (thread_.joinable()) {
        stopping_ = true;
        const std::uint64_t one = 1;
        (void)!write(wake_fd_, &one, sizeof one);
        thread_.join();
    }
    if (fd_ >= 0) {
        ::close(fd_);
        fd_ = -1;
    }
    if (wake_fd_ >= 0) {
        ::close(wake_fd_);
        wake_fd_ = -1;
    }
    set_state(LinkState::Stopped);
}

BoardStatus SerialSource::board_status() const {
    const std::lock_guard lock(status_mutex_);
    return status_copy_;
}

bool SerialSource::open_port() {
    const int fd = ::open(options_.path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        note_error(name() + ": cannot open " + options_.path + ": " + errno_text(errno));
        return false;
    }
    termios tio{};
    if (tcgetattr(fd, &tio) != 0) {
        note_error(name() + ": " + options_.path + " is not a serial port: " + errno_text(errno));
        ::close(fd);
        return false;
    }
    cfmakeraw(&tio);
    tio.c_cflag |= CLOCAL | CREAD;
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    cfsetispeed(&tio, termios_speed(options_.baud));
    cfsetospeed(&tio, termios_speed(options_.baud));
    if (tcsetattr(fd, TCSANOW, &tio) != 0) {
        note_error(name() + ": cannot configure " + options_.path + ": " + errno_text(errno));
        ::close(fd);
        return false;
    }
    // No tcflush: bytes already waiting are the board's, and the decoder resynchronises on
    // whatever partial frame they start with.
    struct stat st{};
    device_id_ = fstat(fd, &st) == 0 ? std::uint64_t(st.st_rdev) : 0;
    fd_ = fd;
    if (ever_opened_) {
        edit_health([](LinkHealth& h) { ++h.reconnects; });
        stream_->restart(now_ns(), "serial port reopened");
    }
    ever_opened_ = true;
    set_state(LinkState::Connecting);
    return true;
}

void SerialSource::close_port(const std::string& why) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    note_error(name() + ": " + options_.path + ": " + why);
    set_state(LinkState::Disconnected);
}

void SerialSource::wait_interruptible(int ms) {
    pollfd p{wake_fd_, POLLIN, 0};
    (void)poll(&p, 1, ms);
}

void SerialSource::sync_health() {
    edit_health([&](LinkHealth& h) { stream_->copy_counters(h); });
    const std::lock_guard lock(status_mutex_);
    status_copy_ = stream_->status();
}

void SerialSource::run() {
    int backoff = options_.backoff_min_ms;
    auto last_node_check = std::chrono::steady_clock::now();
    std::uint8_t buf[4096];
    while (!stopping_) {
        if (fd_ < 0) {
            if (open_port()) {
                backoff = options_.backoff_min_ms;
            } else {
                set_state(LinkState::Disconnected);
                wait_interruptible(backoff);
                backoff = std::min(options_.backoff_max_ms, backoff * 2);
                continue;
            }
        }
        pollfd p[2] = {{fd_, POLLIN, 0}, {wake_fd_, POLLIN, 0}};
        const int r = poll(p, 2, options_.poll_ms);
        if (stopping_) break;
        if (r < 0 && errno != EINTR) {
            close_port("poll: " + errno_text(errno));
            continue;
        }
        if (r > 0 && (p[0].revents & POLLIN)) {
            const ssize_t n = ::read(fd_, buf, sizeof buf);
            if (n > 0) {
                stream_->feed(now_ns(), std::span<const std::uint8_t>(buf, std::size_t(n)));
                sync_health();
            } else if (n == 0) {
                close_port("end of file (device gone)");
                continue;
            } else if (errno != EAGAIN && errno != EINTR) {
                close_port("read: " + errno_text(errno));
                continue;
            }
        } else if (r > 0 && (p[0].revents & (POLLHUP | POLLERR | POLLNVAL))) {
            close_port("hang-up (device unplugged?)");
            continue;
        }
        // A replugged device may come back under the same name as a new node before the old
        // descriptor reports anything: compare what the path names now with what is open.
        const auto now = std::chrono::steady_clock::now();
        if (now - last_node_check > std::chrono::milliseconds(250)) {
            last_node_check = now;
            struct stat st{};
            if (::stat(options_.path.c_str(), &st) != 0) {
                close_port("device node vanished");
                continue;
            }
            if (std::uint64_t(st.st_rdev) != device_id_) {
                close_port("device node now names another device (replugged)");
                continue;
            }
        }
        check_stall();
    }
}

}  // namespace glint::host
