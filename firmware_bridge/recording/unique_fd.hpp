// Owner of one POSIX file descriptor (closed on destruction), and errno as text: the recorder
// and the reader are the only users, both inside this library.
#pragma once

#include <unistd.h>

#include <cstring>
#include <string>
#include <utility>

namespace glint::recording::detail {

class UniqueFd {
public:
    UniqueFd() = default;
    explicit UniqueFd(int fd) : fd_(fd) {}
    UniqueFd(UniqueFd&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
    UniqueFd& operator=(UniqueFd&& other) noexcept {
        if (this != &other) {
            reset();
            fd_ = std::exchange(other.fd_, -1);
        }
        return *this;
    }
    UniqueFd(const UniqueFd&) = delete;
    UniqueFd& operator=(const UniqueFd&) = delete;
    ~UniqueFd() { reset(); }

    int get() const { return fd_; }
    bool valid() const { return fd_ >= 0; }
    // Closes now; returns close()'s result (0 or -1 with errno) so a writer can report it.
    int reset() {
        if (fd_ < 0) return 0;
        return ::close(std::exchange(fd_, -1));
    }

private:
    int fd_ = -1;
};

inline std::string errno_text(int err) { return std::strerror(err); }

}  // namespace glint::recording::detail
