// RecordingReader: opens a recording, validates its header, and returns its intact records in
// file order. Damaged bytes never stop it: a record that fails its checks is reported as an
// issue with its byte offset and the reader resynchronises on the next record's sync marker
// whose CRC is right (FORMAT.md "Resynchronisation"); damage with no intact record after it is
// a torn tail (a write cut by power loss) and ends the file with a warning.
//
// Memory is bounded: the file is read through a window (pread), never loaded whole.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "firmware_bridge/recording/format.hpp"

namespace glint::recording {

enum class IssueKind : std::uint8_t {
    TornTail,        // the file ends inside a record (or in damage that no intact record follows)
    CorruptRecord,   // damaged bytes in the middle, skipped up to the next intact record
    MalformedRecord, // CRC right but the payload does not fit its type (skipped, size trusted)
    StreamGap,       // player: received-stream bytes missing where a damaged record was skipped
};
const char* issue_name(IssueKind kind);

struct ReadIssue {
    IssueKind kind = IssueKind::TornTail;
    std::uint64_t offset = 0;  // file offset where the damage starts
    std::uint64_t size = 0;    // bytes skipped (or missing, for StreamGap)
    std::string message;       // one line naming the file and the offset
};

class RecordingReader {
public:
    // Opens a file and validates its header. Throws RecordingError "PATH: reason at byte N" for
    // a missing file, a stranger file, a newer major version, a truncated or damaged header.
    explicit RecordingReader(const std::string& path);
    // The same over bytes in memory (tests, fuzzing); `name` stands in for the path in messages.
    RecordingReader(Bytes bytes, std::string name);
    ~RecordingReader();
    RecordingReader(RecordingReader&&) noexcept;
    RecordingReader& operator=(RecordingReader&&) noexcept;

    const FileHeader& header() const { return header_; }
    const std::string& path() const { return name_; }
    std::uint64_t file_size() const { return size_; }

    // The next intact record, or nullopt at the end of the file. Damage found on the way is
    // appended to issues() before the record after it is returned.
    std::optional<Record> next();
    const std::vector<ReadIssue>& issues() const { return issues_; }

    // Back to the first record (issues are cleared: they will be found again).
    void rewind();

private:
    class Source;
    std::span<const std::uint8_t> view(std::uint64_t offset, std::size_t n);
    RecordParse try_parse(std::uint64_t offset);
    std::optional<std::uint64_t> find_next_record(std::uint64_t from);
    void open_header();

    std::unique_ptr<Source> source_;
    std::string name_;
    std::uint64_t size_ = 0;
    FileHeader header_;
    std::uint64_t pos_ = 0;
    std::vector<ReadIssue> issues_;
};

}  // namespace glint::recording
