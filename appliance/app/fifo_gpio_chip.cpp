#include "appliance/app/fifo_gpio_chip.hpp"

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstring>
#include <sstream>
#include <string>

#include "appliance/core/errors.hpp"

namespace glint::app {

FifoGpioChip::FifoGpioChip(const std::filesystem::path& fifo, recording::Clock& clock)
    : fifo_(fifo), clock_(clock), chip_(clock, "fifo:" + fifo.string()) {
    struct stat st {};
    if (::stat(fifo.c_str(), &st) != 0 || !S_ISFIFO(st.st_mode))
        throw InputError("gpio.chip: fifo:" + fifo.string() + " is not a named pipe (mkfifo it first)");
    // Read-write so that the pipe never reports end-of-file between two writers.
    fd_ = ::open(fifo.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) throw InputError("gpio.chip: cannot open " + fifo.string() + ": " + std::strerror(errno));
    outputs_.open(fifo.string() + ".out", std::ios::app);
    reader_ = std::thread([this] {
        std::string pending;
        char buffer[256];
        while (!stopping_) {
            pollfd p{fd_, POLLIN, 0};
            if (::poll(&p, 1, 50) <= 0) continue;
            const ssize_t n = ::read(fd_, buffer, sizeof buffer);
            if (n <= 0) continue;
            pending.append(buffer, std::size_t(n));
            std::size_t end;
            while ((end = pending.find('\n')) != std::string::npos) {
                std::istringstream line(pending.substr(0, end));
                pending.erase(0, end + 1);
                unsigned gpio_line = 0;
                int level = 0;
                if (line >> gpio_line >> level) chip_.inject(gpio_line, level != 0, std::int64_t(clock_.now_us()) * 1000);
            }
        }
    });
}

FifoGpioChip::~FifoGpioChip() {
    stopping_ = true;
    if (reader_.joinable()) reader_.join();
    if (fd_ >= 0) ::close(fd_);
}

void FifoGpioChip::set_output(unsigned line, bool high) {
    chip_.set_output(line, high);
    outputs_ << clock_.now_us() * 1000 << ' ' << line << ' ' << (high ? 1 : 0) << std::endl;
}

}  // namespace glint::app
