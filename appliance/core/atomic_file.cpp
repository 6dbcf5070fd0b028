// Atomic file replacement: temp file + fsync + rename + directory fsync.
#include "appliance/core/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <random>
#include <string>

#include "appliance/core/errors.hpp"
#include "appliance/core/unique_fd.hpp"

namespace glint {
namespace {

using Fd = UniqueFd;

void fsync_path(const std::filesystem::path& path, int flags) {
    Fd fd(::open(path.c_str(), flags | O_CLOEXEC));
    if (fd.get() < 0 || ::fsync(fd.get()) != 0)
        throw RuntimeError("cannot fsync " + path.string() + ": " + std::strerror(errno));
}

std::filesystem::path temp_path_for(const std::filesystem::path& target) {
    std::random_device rd;
    return target.parent_path() /
           ("." + target.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" +
            std::to_string(rd()));
}

}  // namespace

void write_file_atomically(const std::filesystem::path& target,
                           const std::function<void(const std::filesystem::path&)>& write) {
    const std::filesystem::path dir =
        target.parent_path().empty() ? std::filesystem::path(".") : target.parent_path();
    const std::filesystem::path tmp = temp_path_for(dir / target.filename());
    try {
        write(tmp);
        fsync_path(tmp, O_RDONLY);
        std::error_code ec;
        std::filesystem::rename(tmp, target, ec);
        if (ec) throw RuntimeError("cannot rename " + tmp.string() + " to " + target.string() +
                                   ": " + ec.message());
        fsync_path(dir, O_RDONLY | O_DIRECTORY);
    } catch (...) {
        std::error_code ignored;
        std::filesystem::remove(tmp, ignored);
        throw;
    }
}

void write_text_atomically(const std::filesystem::path& target, std::string_view text) {
    write_file_atomically(target, [&](const std::filesystem::path& tmp) {
        Fd fd(::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
        if (fd.get() < 0)
            throw RuntimeError("cannot create " + tmp.string() + ": " + std::strerror(errno));
        std::size_t done = 0;
        while (done < text.size()) {
            const ssize_t n = ::write(fd.get(), text.data() + done, text.size() - done);
            if (n < 0) {
                if (errno == EINTR) continue;
                throw RuntimeError("cannot write " + tmp.string() + ": " + std::strerror(errno));
            }
            done += std::size_t(n);
        }
    });
}

void sync_directory(const std::filesystem::path& dir) { fsync_path(dir, O_RDONLY | O_DIRECTORY); }

void ensure_writable_directory(const std::filesystem::path& dir) {
    std::error_code ec;
    if (!std::filesystem::exists(dir, ec)) {
        std::filesystem::create_directories(dir, ec);
        if (ec) throw InputError("output directory " + dir.string() + " cannot be created: " +
                                 ec.message());
    }
    if (!std::filesystem::is_directory(dir, ec))
        throw InputError("output path " + dir.string() + " is not a directory");
    if (::access(dir.c_str(), W_OK | X_OK) != 0)
        throw InputError("output directory " + dir.string() + " is not writable: " +
                         std::strerror(errno));
}

}  // namespace glint
