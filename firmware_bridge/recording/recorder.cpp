// Recorder: buffered appends, writes in blocks, fdatasync on an interval and at close.
#include "firmware_bridge/recording/recorder.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <filesystem>

namespace glint::recording {
namespace {

// Writes all of `bytes`, retrying partial writes and EINTR. Returns 0 or the errno.
int write_all(int fd, std::span<const std::uint8_t> bytes) {
    while (!bytes.empty()) {
        const ssize_t n = ::write(fd, bytes.data(), bytes.size());
        if (n < 0) {
            if (errno == EINTR) continue;
            return errno;
        }
        bytes = bytes.subspan(static_cast<std::size_t>(n));
    }
    return 0;
}

std::int64_t unix_now_us() {
    return std::chrono::duration_cast<std::chrono::microseconds>(
               std::chrono::system_clock::now().time_since_epoch())
        .count();
}

// A new file's directory entry must reach the disk too, or the file may vanish on power loss.
void sync_parent_directory(const std::string& path) {
    std::filesystem::path dir = std::filesystem::path(path).parent_path();
    if (dir.empty()) dir = ".";
    detail::UniqueFd fd(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
    // Best effort: some file systems (and /dev) refuse to sync a directory; the data is synced.
    if (fd.valid()) ::fsync(fd.get());
}

}  // namespace

Recorder::Recorder(std::string path, RecorderOptions options, Clock& clock)
    : path_(std::move(path)), options_(std::move(options)), clock_(clock) {
    header_ = options_.header;
    header_.format_major = kFormatMajor;
    header_.format_minor = kFormatMinor;
    if (header_.created_unix_us == 0) header_.created_unix_us = unix_now_us();
    if (header_.created_monotonic_us == 0) header_.created_monotonic_us = clock_.now_us();
    Bytes head;
    try {
        head = encode_header(header_);
    } catch (const FormatError& e) {
        throw RecordingError("cannot create recording " + path_ + ": " + e.what());
    }
    header_.header_size = static_cast<std::uint32_t>(head.size());

    const int flags = O_WRONLY | O_CREAT | O_CLOEXEC | (options_.overwrite ? O_TRUNC : O_EXCL);
    fd_ = detail::UniqueFd(::open(path_.c_str(), flags, 0644));
    if (!fd_.valid()) throw RecordingError("cannot create recording " + path_ + ": " + detail::errno_text(errno));
    // A file this constructor created but could not start is removed again, so that no
    // header-less file is left to be mistaken for a recording. (A replaced file is gone anyway.)
    auto give_up = [&](const char* what, int err) {
        fd_.reset();
        if (!options_.overwrite) ::unlink(path_.c_str());
        throw RecordingError(std::string(what) + " recording " + path_ + ": " + detail::errno_text(err));
    };
    if (const int err = write_all(fd_.get(), head)) give_up("cannot write the header of", err);
    if (::fdatasync(fd_.get()) != 0 && errno != EINVAL)  // EINVAL: a special file such as a pipe
        give_up("cannot sync", errno);
    sync_parent_directory(path_);
    last_sync_us_ = clock_.now_us();
    buffer_.reserve(options_.block_size + 1024);
}

Recorder::~Recorder() { close(); }

bool Recorder::on_bytes(std::uint64_t time_us, std::span<const std::uint8_t> bytes, Direction direction) {
    std::lock_guard lock(mutex_);
    std::uint64_t& offset = direction == Direction::Received ? rx_offset_ : tx_offset_;
    while (!bytes.empty()) {
        const std::size_t n = std::min(bytes.size(), kMaxRawChunk);
        RawBytesRecord rec;
        rec.time_us = time_us;
        rec.stream_offset = offset;
        rec.direction = direction;
        rec.bytes.assign(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n));
        if (!append(rec)) return false;
        offset += n;
        bytes = bytes.subspan(n);
    }
    return true;
}

bool Recorder::on_sample(std::uint64_t host_time_us, const protocol::FrameEvent& event) {
    if (event.status != protocol::FrameStatus::Ok) return true;
    const auto type = static_cast<std::uint8_t>(event.message.type);
    if (std::find(header_.decoded_types.begin(), header_.decoded_types.end(), type) == header_.decoded_types.end())
        return true;
    return on_message(host_time_us, event.offset, event.seq, event.message);
}

bool Recorder::on_message(std::uint64_t host_time_us, std::uint64_t stream_offset, std::uint16_t seq,
                          const protocol::Message& message) {
    // encode_payload refuses what is_valid refuses; checking first keeps a caller's bad message
    // from being mistaken for a failure of the file.
    if (!protocol::is_valid(message)) return false;
    std::lock_guard lock(mutex_);
    return append(DecodedMessageRecord{host_time_us, stream_offset, seq, message});
}

bool Recorder::on_gpio(std::uint64_t time_us, std::uint32_t line, Edge edge, std::string_view chip) {
    std::lock_guard lock(mutex_);
    return append(GpioEventRecord{time_us, line, edge, std::string(chip)});
}

bool Recorder::mark(std::string_view text) { return mark(clock_.now_us(), text); }

bool Recorder::mark(std::uint64_t time_us, std::string_view text) {
    std::lock_guard lock(mutex_);
    return append(MarkerRecord{time_us, std::string(text)});
}

bool Recorder::on_stream_restart(std::uint64_t time_us, std::string_view reason) {
    std::lock_guard lock(mutex_);
    if (!append(StreamRestartRecord{time_us, std::string(reason)})) return false;
    rx_offset_ = 0;
    tx_offset_ = 0;
    return true;
}

bool Recorder::append(const RecordBody& body) {
    if (closed_ || !error_.empty()) return false;
    Bytes record;
    try {
        record = encode_record(body);
    } catch (const FormatError&) {
        return false;  // e.g. a marker above kMaxRecordPayload: the caller's data, not the file
    }
    buffer_.insert(buffer_.end(), record.begin(), record.end());
    ++records_;
    unsynced_ = true;
    if (buffer_.size() >= options_.block_size && !write_buffer()) return false;
    if (clock_.now_us() - last_sync_us_ >= options_.sync_interval_us) return sync();
    return true;
}

bool Recorder::write_buffer() {
    if (buffer_.empty()) return true;
    if (const int err = write_all(fd_.get(), buffer_)) {
        fail("write failed", err);
        return false;
    }
    buffer_.clear();
    return true;
}

bool Recorder::sync() {
    if (!write_buffer()) return false;
    last_sync_us_ = clock_.now_us();
    if (!unsynced_) return true;
    if (::fdatasync(fd_.get()) != 0 && errno != EINVAL) {
        fail("fdatasync failed", errno);
        return false;
    }
    unsynced_ = false;
    ++syncs_;
    return true;
}

void Recorder::fail(const char* what, int err) {
    error_ = "recording " + path_ + ": " + what + ": " + detail::errno_text(err);
}

bool Recorder::flush() {
    std::lock_guard lock(mutex_);
    if (closed_ || !error_.empty()) return false;
    return sync();
}

bool Recorder::close() {
    std::lock_guard lock(mutex_);
    if (closed_) return error_.empty();
    closed_ = true;
    const bool synced = error_.empty() && sync();
    if (fd_.reset() != 0 && error_.empty()) fail("close failed", errno);
    return synced && error_.empty();
}

bool Recorder::ok() const {
    std::lock_guard lock(mutex_);
    return error_.empty();
}

std::string Recorder::error() const {
    std::lock_guard lock(mutex_);
    return error_;
}

std::uint64_t Recorder::records_written() const {
    std::lock_guard lock(mutex_);
    return records_;
}

std::uint64_t Recorder::syncs() const {
    std::lock_guard lock(mutex_);
    return syncs_;
}

}  // namespace glint::recording
