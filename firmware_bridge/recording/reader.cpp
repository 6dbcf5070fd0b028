// RecordingReader: header validation, record iteration, resynchronisation after damage.
#include "firmware_bridge/recording/reader.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "firmware_bridge/protocol/byte_io.hpp"
#include "firmware_bridge/recording/unique_fd.hpp"

namespace glint::recording {

// Random access to the file's bytes: a file read through a window, or a buffer in memory.
class RecordingReader::Source {
public:
    // Window read ahead on every miss; large enough that records (mostly < 1 KiB) rarely miss.
    static constexpr std::size_t kWindow = 256 * 1024;

    explicit Source(Bytes bytes) : memory_(std::move(bytes)), in_memory_(true) {}
    Source(detail::UniqueFd fd, std::string name) : fd_(std::move(fd)), name_(std::move(name)) {}

    // Up to n bytes at `offset` (fewer at the end of the file); valid until the next call.
    std::span<const std::uint8_t> view(std::uint64_t offset, std::size_t n, std::uint64_t file_size) {
        if (offset >= file_size) return {};
        n = static_cast<std::size_t>(std::min<std::uint64_t>(n, file_size - offset));
        if (in_memory_) return std::span<const std::uint8_t>(memory_).subspan(static_cast<std::size_t>(offset), n);
        if (offset < window_start_ || offset + n > window_start_ + window_.size()) refill(offset, n, file_size);
        return std::span<const std::uint8_t>(window_).subspan(static_cast<std::size_t>(offset - window_start_), n);
    }

private:
    void refill(std::uint64_t offset, std::size_t n, std::uint64_t file_size) {
        const auto want =
            static_cast<std::size_t>(std::min<std::uint64_t>(std::max(n, kWindow), file_size - offset));
        window_.resize(want);
        window_start_ = offset;
        std::size_t got = 0;
        while (got < want) {
            const ssize_t r = ::pread(fd_.get(), window_.data() + got, want - got, static_cast<off_t>(offset + got));
            if (r < 0 && errno == EINTR) continue;
            if (r < 0)
                throw RecordingError(name_ + ": read failed at byte " + std::to_string(offset + got) + ": " +
                                     detail::errno_text(errno));
            if (r == 0) break;  // the file shrank since it was opened: treat the rest as absent
            got += static_cast<std::size_t>(r);
        }
        window_.resize(got);
    }

    Bytes memory_;
    bool in_memory_ = false;
    detail::UniqueFd fd_;
    std::string name_;
    Bytes window_;
    std::uint64_t window_start_ = 0;
};

const char* issue_name(IssueKind kind) {
    switch (kind) {
    case IssueKind::TornTail: return "torn tail";
    case IssueKind::CorruptRecord: return "corrupt record";
    case IssueKind::MalformedRecord: return "malformed record";
    case IssueKind::StreamGap: return "stream gap";
    }
    return "?";
}

RecordingReader::RecordingReader(const std::string& path) : name_(path) {
    detail::UniqueFd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
    if (!fd.valid()) throw RecordingError(path + ": cannot open: " + detail::errno_text(errno));
    struct stat st {};
    if (::fstat(fd.get(), &st) != 0) throw RecordingError(path + ": cannot stat: " + detail::errno_text(errno));
    if (!S_ISREG(st.st_mode)) throw RecordingError(path + ": not a regular file");
    size_ = static_cast<std::uint64_t>(st.st_size);
    source_ = std::make_unique<Source>(std::move(fd), path);
    open_header();
}

RecordingReader::RecordingReader(Bytes bytes, std::string name) : name_(std::move(name)) {
    size_ = bytes.size();
    source_ = std::make_unique<Source>(std::move(bytes));
    open_header();
}

RecordingReader::~RecordingReader() = default;
RecordingReader::RecordingReader(RecordingReader&&) noexcept = default;
RecordingReader& RecordingReader::operator=(RecordingReader&&) noexcept = default;

std::span<const std::uint8_t> RecordingReader::view(std::uint64_t offset, std::size_t n) {
    return source_->view(offset, n, size_);
}

void RecordingReader::open_header() {
    std::span<const std::uint8_t> head = view(0, kPreambleSize);
    if (head.size() == kPreambleSize) {
        // Read as much as the preamble says the header holds (parse_header checks the limits).
        const std::uint32_t header_size = protocol::byte_io::get_u32(head.data() + 12);
        head = view(0, std::clamp<std::size_t>(header_size, kPreambleSize, kMaxHeaderSize));
    }
    if (size_ == 0) throw RecordingError(name_ + ": not a Glint recording (the file is empty)");
    try {
        header_ = parse_header(head);
    } catch (const FormatError& e) {
        throw RecordingError(name_ + ": " + e.what());
    }
    pos_ = header_.header_size;
}

void RecordingReader::rewind() {
    pos_ = header_.header_size;
    issues_.clear();
}

RecordParse RecordingReader::try_parse(std::uint64_t offset) {
    RecordParse p = parse_record(view(offset, kRecordHeaderSize));
    // The header told the size: look again at the whole record (it may still be cut by the end).
    if (p.check == RecordCheck::NeedMore && p.size > 0) p = parse_record(view(offset, p.size));
    return p;
}

std::optional<std::uint64_t> RecordingReader::find_next_record(std::uint64_t from) {
    constexpr std::size_t kScanStep = 64 * 1024;
    std::uint64_t at = from;
    while (at < size_) {
        const auto chunk = view(at, kScanStep);
        const void* hit = std::memchr(chunk.data(), kRecordSync[0], chunk.size());
        if (hit == nullptr) {
            at += chunk.size();
            continue;
        }
        const std::uint64_t candidate =
            at + static_cast<std::uint64_t>(static_cast<const std::uint8_t*>(hit) - chunk.data());
        // Only a record whose CRC matches counts: a sync pattern inside damaged bytes or inside a
        // payload fails it (a false match needs a 32-bit CRC collision).
        const RecordParse p = try_parse(candidate);
        if (p.check == RecordCheck::Ok || p.check == RecordCheck::Malformed) return candidate;
        at = candidate + 1;
    }
    return std::nullopt;
}

std::optional<Record> RecordingReader::next() {
    while (pos_ < size_) {
        const RecordParse p = try_parse(pos_);
        if (p.check == RecordCheck::Ok) {
            Record record{pos_, static_cast<std::uint32_t>(p.size), *p.body};
            pos_ += p.size;
            return record;
        }
        if (p.check == RecordCheck::Malformed) {
            // The CRC matched, so the size is the writer's: skip exactly this record.
            issues_.push_back({IssueKind::MalformedRecord, pos_, p.size,
                               name_ + ": malformed record at byte " + std::to_string(pos_) + " skipped: " + p.detail});
            pos_ += p.size;
            continue;
        }
        const std::optional<std::uint64_t> resume = find_next_record(pos_ + 1);
        if (!resume) {
            issues_.push_back({IssueKind::TornTail, pos_, size_ - pos_,
                               name_ + ": torn record at byte " + std::to_string(pos_) + " (" + check_name(p.check) +
                                   "): the last " + std::to_string(size_ - pos_) +
                                   " bytes of the file are ignored"});
            pos_ = size_;
            return std::nullopt;
        }
        issues_.push_back({IssueKind::CorruptRecord, pos_, *resume - pos_,
                           name_ + ": damaged record at byte " + std::to_string(pos_) + " (" + check_name(p.check) +
                               "): skipped " + std::to_string(*resume - pos_) + " bytes to the next record at byte " +
                               std::to_string(*resume)});
        pos_ = *resume;
    }
    return std::nullopt;
}

}  // namespace glint::recording
