// verify_recording: a PlaybackSink that pairs replayed Ok frames with recorded messages.
#include "firmware_bridge/recording/verify.hpp"

#include <algorithm>
#include <deque>

#include "firmware_bridge/recording/text.hpp"

namespace glint::recording {
namespace {

class VerifySink final : public PlaybackSink {
public:
    VerifySink(const FileHeader& header, VerifyReport& report, std::size_t max_mismatches)
        : types_(header.decoded_types), report_(report), max_(max_mismatches),
          decoded_only_(!transport_has_byte_stream(header.transport)) {
        report_.decoded_only = decoded_only_;
    }

    void on_frame(std::uint64_t host_time_us, const protocol::FrameEvent& event) override {
        if (event.status != protocol::FrameStatus::Ok) return;
        const auto type = static_cast<std::uint8_t>(event.message.type);
        if (std::find(types_.begin(), types_.end(), type) == types_.end()) return;
        ++report_.replayed_messages;
        replayed_.push_back(DecodedMessageRecord{host_time_us, event.offset, event.seq, event.message});
        pair_up();
    }
    void on_record(const Record& record) override {
        if (const auto* m = std::get_if<DecodedMessageRecord>(&record.body)) {
            ++report_.recorded_messages;
            if (decoded_only_) return;  // nothing to pair them with
            recorded_.push_back(*m);
            pair_up();
        }
    }
    void on_issue(const ReadIssue& issue) override { report_.issues.push_back(issue); }

    // After the replay: what is left on one side has no partner on the other.
    void finish() {
        if (decoded_only_) return;
        if (report_.recorded_messages != report_.replayed_messages)
            add_mismatch(std::to_string(report_.recorded_messages) + " messages recorded, " +
                         std::to_string(report_.replayed_messages) + " replayed");
    }

private:
    // Compares the two streams in order as they arrive; memory stays bounded by how far the
    // recorded records lag the raw bytes (a chunk's worth), not by the file's length.
    void pair_up() {
        while (!recorded_.empty() && !replayed_.empty()) {
            if (recorded_.front() == replayed_.front()) {
                if (report_.mismatches.empty()) ++report_.matching_messages;
            } else {
                add_mismatch("message " + std::to_string(index_) + ": recorded " + describe(recorded_.front()) +
                             " | replayed " + describe(replayed_.front()));
            }
            recorded_.pop_front();
            replayed_.pop_front();
            ++index_;
        }
    }
    void add_mismatch(std::string text) {
        if (report_.mismatches.size() < max_) report_.mismatches.push_back(std::move(text));
        else ++report_.mismatches_not_shown;
    }

    std::vector<std::uint8_t> types_;
    VerifyReport& report_;
    std::size_t max_;
    std::deque<DecodedMessageRecord> recorded_;
    std::deque<DecodedMessageRecord> replayed_;
    std::uint64_t index_ = 0;
    bool decoded_only_ = false;
};

}  // namespace

std::string describe(const DecodedMessageRecord& record) {
    return "t=" + std::to_string(record.host_time_us) + "us offset=" + std::to_string(record.stream_offset) +
           " seq=" + std::to_string(record.seq) + " " + describe_message(record.message);
}

VerifyReport verify_recording(RecordingReader& reader, std::size_t max_mismatches) {
    VerifyReport report;
    VerifySink sink(reader.header(), report, max_mismatches);
    VirtualClock clock;
    Player player(reader, clock);
    report.playback = player.play(sink);
    sink.finish();
    return report;
}

}  // namespace glint::recording
