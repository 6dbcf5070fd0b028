// libFuzzer target for the protocol: arbitrary bytes into FrameDecoder (in chunks chosen by the
// input, and byte by byte), COBS and the payload codec. Checks, besides memory safety under ASan
// and UBSan: chunking never changes the result, every byte is accounted for, every accepted
// message re-encodes to a message that decodes back equal, and COBS round-trips what it decodes.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <span>

#include "firmware_bridge/protocol/cobs.hpp"
#include "firmware_bridge/protocol/frame.hpp"
#include "firmware_bridge/protocol/frame_decoder.hpp"
#include "firmware_bridge/protocol/messages.hpp"

namespace {

using namespace glint::protocol;

void check(bool ok) {
    if (!ok) std::abort();
}

void check_event(const FrameDecoder& decoder, const FrameEvent& e) {
    check(e.offset + e.size == decoder.stream_offset());
    if (e.status != FrameStatus::Ok) return;
    check(e.size <= kMaxFrameSize && e.header_valid);
    // The accepted message must be valid and survive a re-encode.
    check(is_valid(e.message));
    std::uint8_t payload[kMaxPayloadSize];
    const PayloadResult p = encode_payload(e.message, payload);
    check(p.status == PayloadStatus::Ok);
    Message back;
    check(decode_payload(e.type, std::span<const std::uint8_t>(payload, p.size), back) == PayloadStatus::Ok);
    check(back == e.message);
    std::uint8_t frame[kMaxFrameSize];
    check(encode_frame(e.message, e.seq, frame).status == EncodeStatus::Ok);
}

void check_accounting(const FrameDecoder& d) {
    const DecoderStats& s = d.stats();
    check(s.bytes_in == s.bytes_accepted + s.bytes_discarded + s.idle_delimiters + d.pending_bytes());
}

// The decoder checks of one byte stream: chunked and byte-by-byte feeding must agree.
void run_stream(std::span<const std::uint8_t> input, std::size_t chunk) {
    FrameDecoder chunked;
    std::span<const std::uint8_t> rest = input;
    FrameEvent event;
    while (!rest.empty()) {
        const std::span<const std::uint8_t> piece = rest.first(rest.size() < chunk ? rest.size() : chunk);
        std::span<const std::uint8_t> left = piece;
        while (!left.empty()) {
            const FrameDecoder::FeedResult r = chunked.feed(left, event);
            check(r.consumed > 0 && r.consumed <= left.size());
            left = left.subspan(r.consumed);
            if (r.has_event) check_event(chunked, event);
        }
        rest = rest.subspan(piece.size());
    }
    check_accounting(chunked);

    FrameDecoder bytewise;
    for (const std::uint8_t byte : input) {
        bytewise.feed_all(std::span<const std::uint8_t>(&byte, 1), [&](const FrameEvent& e) { check_event(bytewise, e); });
    }
    check(bytewise.stats() == chunked.stats());
    if (chunked.finish(event)) check(event.status == FrameStatus::TruncatedAtEnd);
    check(chunked.pending_bytes() == 0);
    check_accounting(chunked);
}

// Random bytes almost never pass the CRC, so this mode wraps input pieces in valid frames:
// [type][length][payload ...] repeated, each sent with a correct CRC, so that arbitrary
// payloads reach the payload decoder through the whole pipeline.
void run_valid_frames(std::span<const std::uint8_t> input, std::size_t chunk) {
    static std::uint8_t stream[64 * kMaxFrameSize];
    std::size_t used = 0;
    std::uint16_t seq = 0;
    while (input.size() >= 2 && used + kMaxFrameSize <= sizeof stream) {
        const std::uint8_t type = input[0];
        std::size_t length = input[1];
        input = input.subspan(2);
        if (length > input.size()) length = input.size();
        if (length > kMaxPayloadSize) length = kMaxPayloadSize;
        const EncodeResult r = encode_raw_frame(kVersionMajor, type, seq++, input.first(length),
                                                std::span<std::uint8_t>(stream + used, kMaxFrameSize));
        check(r.status == EncodeStatus::Ok);
        used += r.size;
        input = input.subspan(length);
    }
    run_stream(std::span<const std::uint8_t>(stream, used), chunk);
    FrameDecoder d;
    d.feed_all(std::span<const std::uint8_t>(stream, used), [](const FrameEvent& e) {
        check(e.header_valid);  // every frame was built valid: only payload checks may fail
    });
    check(d.stats().crc_errors + d.stats().cobs_errors + d.stats().too_short + d.stats().oversize_frames == 0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    if (size == 0) return 0;
    const std::size_t chunk = 1 + (data[0] & 0x3F);
    const std::span<const std::uint8_t> input(data + 1, size - 1);
    if (data[0] & 0x80) {
        run_valid_frames(input, chunk);
        return 0;
    }
    run_stream(input, chunk);

    // COBS: whatever decodes must re-encode to something that decodes to the same bytes.
    std::uint8_t decoded[1024];
    std::uint8_t reencoded[cobs_max_encoded_size(sizeof decoded)];
    std::uint8_t again[1024];
    if (input.size() <= sizeof decoded) {
        const CobsResult d = cobs_decode(input, decoded);
        if (d.ok) {
            const CobsResult e = cobs_encode(std::span<const std::uint8_t>(decoded, d.size), reencoded);
            check(e.ok && e.size <= cobs_max_encoded_size(d.size));
            const CobsResult d2 = cobs_decode(std::span<const std::uint8_t>(reencoded, e.size), again);
            check(d2.ok && d2.size == d.size);
            for (std::size_t i = 0; i < d.size; ++i) check(again[i] == decoded[i]);
        }
    }

    // The payload codec on raw bytes of every type.
    Message m;
    for (int type = 0; type < 256; ++type) {
        if (decode_payload(static_cast<std::uint8_t>(type), input, m) == PayloadStatus::Ok) check(is_valid(m));
    }
    return 0;
}
