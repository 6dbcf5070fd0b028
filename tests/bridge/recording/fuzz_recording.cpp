// libFuzzer target for recorded sensor files: arbitrary bytes as a recording, through the
// reader (records and issues), a second pass after rewind(), and the player (raw bytes through
// the real FrameDecoder) on a virtual clock. Checks, besides memory safety under ASan and UBSan:
// header errors are RecordingError only; records come in strictly increasing, non-overlapping
// file offsets inside the file; issues point inside the file; rewinding reads the same records
// and issues again; two replays give the same decoder statistics.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <optional>
#include <vector>

#include "firmware_bridge/recording/clock.hpp"
#include "firmware_bridge/recording/format.hpp"
#include "firmware_bridge/recording/player.hpp"
#include "firmware_bridge/recording/reader.hpp"

namespace {

using namespace glint::recording;

void check(bool ok) {
    if (!ok) std::abort();
}

struct Seen {
    std::vector<std::uint64_t> offsets;
    std::vector<std::uint32_t> sizes;
    std::vector<std::uint64_t> issue_offsets;
    bool operator==(const Seen&) const = default;
};

Seen read_all(RecordingReader& reader) {
    Seen seen;
    std::uint64_t end_of_last = 0;
    while (const auto record = reader.next()) {
        check(record->offset >= end_of_last);
        check(record->size > 0 && record->offset + record->size <= reader.file_size());
        end_of_last = record->offset + record->size;
        seen.offsets.push_back(record->offset);
        seen.sizes.push_back(record->size);
    }
    for (const ReadIssue& issue : reader.issues()) {
        check(issue.offset <= reader.file_size());
        check(!issue.message.empty());
        seen.issue_offsets.push_back(issue.offset);
    }
    return seen;
}

class CountingSink final : public PlaybackSink {
public:
    std::uint64_t frames = 0;
    std::uint64_t last_time_us = 0;
    void on_frame(std::uint64_t host_time_us, const glint::protocol::FrameEvent&) override {
        ++frames;
        last_time_us = host_time_us;
    }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    std::optional<RecordingReader> reader;
    try {
        reader.emplace(Bytes(data, data + size), "fuzz.glrec");
    } catch (const RecordingError&) {
        return 0;  // a bad header is refused with a message; nothing else may be thrown
    }
    const Seen first = read_all(*reader);
    reader->rewind();
    const Seen second = read_all(*reader);
    check(first == second);

    VirtualClock clock_a(0), clock_b(0);
    CountingSink sink_a, sink_b;
    const PlaybackResult a = Player(*reader, clock_a).play(sink_a);
    const PlaybackResult b = Player(*reader, clock_b).play(sink_b);
    check(a.stats == b.stats && a.records == b.records && sink_a.frames == sink_b.frames);
    check(a.records == first.offsets.size());
    return 0;
}
