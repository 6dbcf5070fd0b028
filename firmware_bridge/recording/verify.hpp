// Verification of a recording: every record intact (CRC and layout), and the replay of the
// received raw bytes through the real FrameDecoder reproduces the DecodedMessage records exactly
// (same messages in the same order with the same receive time, stream offset and seq), for the
// message types the header says were recorded.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "firmware_bridge/recording/player.hpp"
#include "firmware_bridge/recording/reader.hpp"

namespace glint::recording {

struct VerifyReport {
    std::vector<ReadIssue> issues;          // damage found in the file (and stream gaps)
    std::uint64_t recorded_messages = 0;    // DecodedMessage records in the file
    std::uint64_t replayed_messages = 0;    // Ok frames of a recorded type in the replay
    std::uint64_t matching_messages = 0;    // messages equal on both sides before the first difference
    std::vector<std::string> mismatches;    // the first few differences, one line each
    std::uint64_t mismatches_not_shown = 0; // differences beyond max_mismatches
    PlaybackResult playback;
    // A transport without a byte stream (I2C, Modbus): its decoded records are all there is, so
    // there is nothing to replay them against (transport_has_byte_stream).
    bool decoded_only = false;

    bool replay_matches() const {
        if (decoded_only) return mismatches.empty() && mismatches_not_shown == 0;
        return mismatches.empty() && mismatches_not_shown == 0 && recorded_messages == replayed_messages &&
               matching_messages == recorded_messages;
    }
    bool intact() const { return issues.empty(); }
};

// Replays the whole file as fast as possible (virtual clock) and compares. At most
// `max_mismatches` differences are described.
VerifyReport verify_recording(RecordingReader& reader, std::size_t max_mismatches = 10);

// One line describing a decoded message record ("t=... offset=... seq=... orientation ...").
std::string describe(const DecodedMessageRecord& record);

}  // namespace glint::recording
