// Player: paced replay of the received stream through a fresh FrameDecoder per stream segment.
#include "firmware_bridge/recording/player.hpp"

#include <memory>

namespace glint::recording {

void accumulate(protocol::DecoderStats& total, const protocol::DecoderStats& part) {
    total.bytes_in += part.bytes_in;
    total.bytes_accepted += part.bytes_accepted;
    total.bytes_discarded += part.bytes_discarded;
    total.idle_delimiters += part.idle_delimiters;
    total.frames_ok += part.frames_ok;
    total.cobs_errors += part.cobs_errors;
    total.too_short += part.too_short;
    total.crc_errors += part.crc_errors;
    total.version_mismatches += part.version_mismatches;
    total.unknown_types += part.unknown_types;
    total.bad_lengths += part.bad_lengths;
    total.bad_values += part.bad_values;
    total.oversize_frames += part.oversize_frames;
    total.truncated_at_end += part.truncated_at_end;
    total.extended_payloads += part.extended_payloads;
    total.lost_frames += part.lost_frames;
    total.sender_restarts += part.sender_restarts;
}

PlaybackResult Player::play(PlaybackSink& sink) {
    reader_.rewind();
    PlaybackResult result;
    // ~0.8 KiB of fixed buffers: kept off the stack of whoever calls play().
    auto decoder = std::make_unique<protocol::FrameDecoder>();
    std::uint64_t expected_rx_offset = 0;  // where the next received chunk should start
    std::uint64_t last_rx_time_us = 0;     // stamp for a frame cut off by the end of a segment
    std::size_t issues_seen = 0;
    bool have_start = false;
    std::uint64_t clock_start_us = 0;

    auto report_new_issues = [&] {
        for (; issues_seen < reader_.issues().size(); ++issues_seen) {
            sink.on_issue(reader_.issues()[issues_seen]);
            ++result.issues;
        }
    };
    // Ends a stream segment: a frame still open is reported as TruncatedAtEnd.
    auto finish_segment = [&] {
        protocol::FrameEvent event;
        if (decoder->finish(event)) sink.on_frame(last_rx_time_us, event);
        accumulate(result.stats, decoder->stats());
        decoder->reset();
        expected_rx_offset = 0;
    };

    while (const std::optional<Record> record = reader_.next()) {
        report_new_issues();
        ++result.records;
        if (const std::optional<std::uint64_t> t = record_time_us(record->body)) {
            if (!have_start) {
                have_start = true;
                clock_start_us = clock_.now_us();
                result.first_time_us = *t;
            }
            // A time before the first record (a clock that stepped back) plays at once.
            const std::uint64_t since_first = *t > result.first_time_us ? *t - result.first_time_us : 0;
            clock_.sleep_until_us(clock_start_us + since_first);
            result.last_time_us = *t;
        }

        if (const auto* raw = std::get_if<RawBytesRecord>(&record->body);
            raw != nullptr && raw->direction == Direction::Received) {
            if (raw->stream_offset != expected_rx_offset) {
                // Bytes of a skipped (damaged) record are missing: the decoder will reject the
                // frame they belonged to; say why before it does.
                const std::uint64_t missing =
                    raw->stream_offset > expected_rx_offset ? raw->stream_offset - expected_rx_offset : 0;
                const ReadIssue gap{IssueKind::StreamGap, record->offset, missing,
                                    reader_.path() + ": received stream offset " + std::to_string(raw->stream_offset) +
                                        " in the record at byte " + std::to_string(record->offset) + ", expected " +
                                        std::to_string(expected_rx_offset) + " (bytes of a skipped record are missing)"};
                sink.on_issue(gap);
                ++result.issues;
            }
            expected_rx_offset = raw->stream_offset + raw->bytes.size();
            last_rx_time_us = raw->time_us;
            decoder->feed_all(raw->bytes,
                              [&](const protocol::FrameEvent& event) { sink.on_frame(raw->time_us, event); });
        } else if (std::holds_alternative<StreamRestartRecord>(record->body)) {
            finish_segment();
            ++result.stream_restarts;
        }
        sink.on_record(*record);
    }
    report_new_issues();
    finish_segment();
    return result;
}

}  // namespace glint::recording
