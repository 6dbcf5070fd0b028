// FrameDecoder: chunking at every split point, sequence gaps and wrap, unknown types, short and
// long payloads, oversize frames, truncated streams, byte offsets and byte accounting.
#include <gtest/gtest.h>

#include "protocol_test_support.hpp"

namespace glint::protocol {
namespace {

using test::Bytes;

// Every sample message once, numbered from `first_seq`, back to back.
Bytes sample_stream(std::uint16_t first_seq, std::vector<std::uint64_t>* offsets = nullptr) {
    Bytes stream;
    std::uint16_t seq = first_seq;
    for (const Message& m : test::sample_messages()) {
        if (offsets) offsets->push_back(stream.size());
        test::append(stream, test::encode(m, seq++));
    }
    return stream;
}

void expect_same_events(const std::vector<FrameEvent>& a, const std::vector<FrameEvent>& b, const char* what) {
    ASSERT_EQ(a.size(), b.size()) << what;
    for (std::size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a[i].status, b[i].status) << what << " event " << i;
        EXPECT_EQ(a[i].offset, b[i].offset) << what << " event " << i;
        EXPECT_EQ(a[i].size, b[i].size) << what << " event " << i;
        EXPECT_EQ(a[i].seq, b[i].seq) << what << " event " << i;
        EXPECT_EQ(a[i].lost_before, b[i].lost_before) << what << " event " << i;
        if (a[i].status == FrameStatus::Ok) {
            EXPECT_TRUE(a[i].message == b[i].message) << what << " event " << i;
        }
    }
}

TEST(FrameDecoder, ReportsEachFrameWithItsStartOffset) {
    std::vector<std::uint64_t> offsets;
    const Bytes stream = sample_stream(0, &offsets);
    FrameDecoder d;
    const auto events = test::decode_stream(d, stream);
    ASSERT_EQ(events.size(), offsets.size());
    for (std::size_t i = 0; i < events.size(); ++i) {
        EXPECT_EQ(events[i].status, FrameStatus::Ok);
        EXPECT_EQ(events[i].offset, offsets[i]);
        EXPECT_EQ(events[i].lost_before, 0);
    }
    EXPECT_EQ(d.stats().frames_ok, offsets.size());
    EXPECT_EQ(d.stats().bytes_accepted, stream.size());
    EXPECT_EQ(d.stats().bytes_discarded, 0u);
    EXPECT_EQ(d.stream_offset(), stream.size());
    test::expect_bytes_accounted(d);
}

TEST(FrameDecoder, SameEventsForEverySplitPointAndByteByByte) {
    Bytes stream{0x00, 0x13, 0x37};  // idle delimiter, then garbage glued to the first frame
    test::append(stream, sample_stream(40));
    stream.push_back(0x00);
    test::append(stream, sample_stream(7));
    FrameDecoder whole_decoder;
    const auto whole = test::decode_stream(whole_decoder, stream);
    ASSERT_GT(whole.size(), 20u);
    EXPECT_EQ(whole[0].status, FrameStatus::CrcError);  // garbage + first frame
    EXPECT_EQ(whole[0].offset, 1u);

    for (std::size_t split = 0; split <= stream.size(); ++split) {
        FrameDecoder d;
        std::vector<FrameEvent> events;
        const std::span<const std::uint8_t> all(stream);
        d.feed_all(all.first(split), [&](const FrameEvent& e) { events.push_back(e); });
        d.feed_all(all.subspan(split), [&](const FrameEvent& e) { events.push_back(e); });
        expect_same_events(events, whole, "two chunks");
        EXPECT_EQ(d.stats(), whole_decoder.stats()) << "split " << split;
    }
    FrameDecoder bytewise;
    expect_same_events(test::decode_stream(bytewise, stream, 1), whole, "byte by byte");
    EXPECT_EQ(bytewise.stats(), whole_decoder.stats());
    for (std::size_t chunk : {2u, 3u, 7u, 64u, 255u, 256u, 257u}) {
        FrameDecoder d;
        expect_same_events(test::decode_stream(d, stream, chunk), whole, "chunked");
    }
}

TEST(FrameDecoder, PollApiStopsAfterEachFrame) {
    const Bytes stream = sample_stream(0);
    FrameDecoder d;
    FrameEvent e;
    std::span<const std::uint8_t> rest(stream);
    std::size_t frames = 0;
    while (!rest.empty()) {
        const auto r = d.feed(rest, e);
        ASSERT_GT(r.consumed, 0u);
        rest = rest.subspan(r.consumed);
        if (r.has_event) {
            ++frames;
            EXPECT_EQ(e.offset + e.size, d.stream_offset());  // the frame ended at the last byte consumed
        }
    }
    EXPECT_EQ(frames, test::sample_messages().size());
}

TEST(FrameDecoder, CountsLostFramesAcrossSequenceWrap) {
    const Message m = test::sample_orientation();
    Bytes stream;
    // 65533, 65534, [65535 lost], 0, [1, 2 lost], 3
    for (const std::uint16_t seq : std::vector<std::uint16_t>{65533, 65534, 0, 3}) test::append(stream, test::encode(m, seq));
    FrameDecoder d;
    const auto events = test::decode_stream(d, stream);
    ASSERT_EQ(events.size(), 4u);
    EXPECT_EQ(events[0].lost_before, 0);
    EXPECT_EQ(events[1].lost_before, 0);
    EXPECT_EQ(events[2].lost_before, 1);
    EXPECT_EQ(events[3].lost_before, 2);
    EXPECT_EQ(d.stats().lost_frames, 3u);
}

TEST(FrameDecoder, HelloWithSequenceZeroRestartsTrackingWithoutCountingAGap) {
    const auto samples = test::sample_messages();
    const Message hello = samples[0];
    ASSERT_EQ(hello.type, MessageType::Hello);
    Bytes stream;
    test::append(stream, test::encode(test::sample_orientation(), 500));
    test::append(stream, test::encode(hello, 0));  // board reset
    test::append(stream, test::encode(test::sample_orientation(), 1));
    test::append(stream, test::encode(hello, 9));  // a requested Hello mid-session: normal frame
    FrameDecoder d;
    const auto events = test::decode_stream(d, stream);
    ASSERT_EQ(events.size(), 4u);
    EXPECT_EQ(events[1].lost_before, 0);
    EXPECT_EQ(events[3].lost_before, 7);
    EXPECT_EQ(d.stats().sender_restarts, 1u);
    EXPECT_EQ(d.stats().lost_frames, 7u);
}

TEST(FrameDecoder, RestartSequenceForgetsThePreviousNumber) {
    FrameDecoder d;
    test::decode_stream(d, test::encode(test::sample_orientation(), 10));
    d.restart_sequence();
    const auto events = test::decode_stream(d, test::encode(test::sample_orientation(), 4000));
    ASSERT_EQ(events.size(), 1u);
    EXPECT_EQ(events[0].lost_before, 0);
    EXPECT_EQ(d.stats().lost_frames, 0u);
}

TEST(FrameDecoder, UnknownTypeIsReportedWithItsTypeAndStillCountsSequence) {
    Bytes stream = test::encode(test::sample_orientation(), 1);
    test::append(stream, test::encode_raw(kVersionMajor, 0x42, 2, {1, 2, 3}));
    test::append(stream, test::encode(test::sample_orientation(), 3));
    FrameDecoder d;
    const auto events = test::decode_stream(d, stream);
    ASSERT_EQ(events.size(), 3u);
    EXPECT_EQ(events[1].status, FrameStatus::UnknownType);
    EXPECT_TRUE(events[1].header_valid);
    EXPECT_EQ(events[1].type, 0x42);
    EXPECT_EQ(events[1].payload_size, 3);
    EXPECT_EQ(events[2].status, FrameStatus::Ok);
    EXPECT_EQ(d.stats().unknown_types, 1u);
    EXPECT_EQ(d.stats().lost_frames, 0u);  // frame 2 arrived, it just was not understood
    test::expect_bytes_accounted(d);
}

TEST(FrameDecoder, TruncatedPayloadIsBadLengthForEveryTypeAndEveryShorterLength) {
    for (const Message& m : test::sample_messages()) {
        const Bytes payload = test::payload_of(m);
        for (std::size_t len = 0; len < payload.size(); ++len) {
            const Bytes frame = test::encode_raw(kVersionMajor, static_cast<std::uint8_t>(m.type), 0,
                                                 Bytes(payload.begin(), payload.begin() + static_cast<long>(len)));
            FrameDecoder d;
            const auto events = test::decode_stream(d, frame);
            ASSERT_EQ(events.size(), 1u);
            EXPECT_EQ(events[0].status, FrameStatus::BadLength) << type_name(events[0].type) << " len " << len;
            EXPECT_EQ(events[0].type, static_cast<std::uint8_t>(m.type));
            EXPECT_EQ(events[0].payload_size, len);
            EXPECT_EQ(d.stats().bad_lengths, 1u);
        }
    }
}

TEST(FrameDecoder, LongerPayloadFromANewerMinorIsAcceptedAndExtraBytesIgnored) {
    for (const Message& m : test::sample_messages()) {
        Bytes payload = test::payload_of(m);
        const std::size_t known = payload.size();
        test::append(payload, {0xAB, 0x00, 0xCD, 0xEF});  // fields appended by version 1.1
        const Bytes frame = test::encode_raw(kVersionMajor, static_cast<std::uint8_t>(m.type), 3, payload);
        FrameDecoder d;
        const auto events = test::decode_stream(d, frame);
        ASSERT_EQ(events.size(), 1u);
        EXPECT_EQ(events[0].status, FrameStatus::Ok);
        EXPECT_TRUE(events[0].extended);
        EXPECT_EQ(events[0].payload_size, known + 4);
        EXPECT_TRUE(events[0].message == m) << type_name(static_cast<std::uint8_t>(m.type));
        EXPECT_EQ(d.stats().extended_payloads, 1u);
    }
}

TEST(FrameDecoder, OtherMajorVersionIsRejectedAndLeavesSequenceAlone) {
    Bytes stream = test::encode(test::sample_orientation(), 1);
    test::append(stream, test::encode_raw(kVersionMajor + 1, 0x02, 900, test::payload_of(test::sample_orientation())));
    test::append(stream, test::encode(test::sample_orientation(), 2));
    FrameDecoder d;
    const auto events = test::decode_stream(d, stream);
    ASSERT_EQ(events.size(), 3u);
    EXPECT_EQ(events[1].status, FrameStatus::VersionMismatch);
    EXPECT_EQ(events[1].version_major, kVersionMajor + 1);
    EXPECT_EQ(events[2].lost_before, 0);
    EXPECT_EQ(d.stats().version_mismatches, 1u);
}

TEST(FrameDecoder, CorruptedFrameIsCrcErrorAndNextFrameDecodes) {
    Bytes first = test::encode(test::sample_orientation(), 1);
    first[5] ^= 0x10;  // stays non-zero: 0x10 flips a bit that cannot make the byte 0 here
    ASSERT_NE(first[5], 0);
    Bytes stream = first;
    test::append(stream, test::encode(test::sample_orientation(), 2));
    FrameDecoder d;
    const auto events = test::decode_stream(d, stream);
    ASSERT_EQ(events.size(), 2u);
    EXPECT_EQ(events[0].status, FrameStatus::CrcError);
    EXPECT_FALSE(events[0].header_valid);
    EXPECT_EQ(events[1].status, FrameStatus::Ok);
    EXPECT_EQ(events[1].offset, first.size());
    EXPECT_EQ(d.stats().crc_errors, 1u);
    EXPECT_EQ(d.stats().bytes_discarded, first.size());
}

TEST(FrameDecoder, ShortAndMalformedFramesAreClassified) {
    FrameDecoder d;
    // 0x05 claims 4 data bytes but only 1 follows: COBS error. 02 11 decodes to 1 byte: too short.
    const auto events = test::decode_stream(d, Bytes{0x05, 0x11, 0x00, 0x02, 0x11, 0x00});
    ASSERT_EQ(events.size(), 2u);
    EXPECT_EQ(events[0].status, FrameStatus::CobsError);
    EXPECT_EQ(events[1].status, FrameStatus::TooShort);
    EXPECT_EQ(events[1].offset, 3u);
    EXPECT_EQ(d.stats().cobs_errors, 1u);
    EXPECT_EQ(d.stats().too_short, 1u);
    EXPECT_EQ(d.stats().bytes_discarded, 6u);
}

TEST(FrameDecoder, OversizeRunIsDiscardedUpToTheNextDelimiter) {
    Bytes stream(1000, 0x7A);  // a long run with no delimiter (e.g. wrong baud rate)
    stream.push_back(0x00);
    const Bytes good = test::encode(test::sample_orientation(), 8);
    test::append(stream, good);
    FrameDecoder d;
    const auto events = test::decode_stream(d, stream);
    ASSERT_EQ(events.size(), 2u);
    EXPECT_EQ(events[0].status, FrameStatus::Oversize);
    EXPECT_EQ(events[0].offset, 0u);
    EXPECT_EQ(events[0].size, 1001u);
    EXPECT_EQ(events[1].status, FrameStatus::Ok);
    EXPECT_EQ(events[1].offset, 1001u);
    EXPECT_EQ(d.stats().oversize_frames, 1u);
    EXPECT_EQ(d.stats().bytes_discarded, 1001u);
    test::expect_bytes_accounted(d);
}

TEST(FrameDecoder, LongestLegalFrameIsNotOversize) {
    const Bytes frame = test::encode_raw(kVersionMajor, 0x7F, 1, Bytes(kMaxPayloadSize, 0x5A));
    ASSERT_EQ(frame.size(), kMaxFrameSize);
    FrameDecoder d;
    const auto events = test::decode_stream(d, frame);
    ASSERT_EQ(events.size(), 1u);
    EXPECT_EQ(events[0].status, FrameStatus::UnknownType);  // intact, just a type we do not know
    EXPECT_EQ(events[0].payload_size, kMaxPayloadSize);
    // One byte more between delimiters is oversize.
    Bytes longer(frame.begin(), frame.end() - 1);
    longer.insert(longer.begin(), 0x01);
    longer.push_back(0x00);
    FrameDecoder d2;
    const auto events2 = test::decode_stream(d2, longer);
    ASSERT_EQ(events2.size(), 1u);
    EXPECT_EQ(events2[0].status, FrameStatus::Oversize);
}

TEST(FrameDecoder, StreamEndingInsideAFrameIsReportedByFinish) {
    const Bytes frame = test::encode(test::sample_orientation(), 1);
    Bytes stream = frame;
    stream.insert(stream.end(), frame.begin(), frame.begin() + 10);  // file cut mid-frame
    FrameDecoder d;
    const auto events = test::decode_stream(d, stream, 4096, /*finish=*/false);
    ASSERT_EQ(events.size(), 1u);
    EXPECT_EQ(d.pending_bytes(), 10u);
    test::expect_bytes_accounted(d);
    FrameEvent tail;
    ASSERT_TRUE(d.finish(tail));
    EXPECT_EQ(tail.status, FrameStatus::TruncatedAtEnd);
    EXPECT_EQ(tail.offset, frame.size());
    EXPECT_EQ(tail.size, 10u);
    EXPECT_EQ(d.pending_bytes(), 0u);
    EXPECT_FALSE(d.finish(tail));
    EXPECT_EQ(d.stats().truncated_at_end, 1u);
    test::expect_bytes_accounted(d);
}

TEST(FrameDecoder, IdleDelimitersAreNeitherFramesNorErrors) {
    Bytes stream{0x00, 0x00, 0x00};
    test::append(stream, test::encode(test::sample_orientation(), 1));
    stream.push_back(0x00);
    FrameDecoder d;
    const auto events = test::decode_stream(d, stream);
    ASSERT_EQ(events.size(), 1u);
    EXPECT_EQ(events[0].offset, 3u);
    EXPECT_EQ(d.stats().idle_delimiters, 4u);
    EXPECT_EQ(d.stats().bytes_discarded, 0u);
    test::expect_bytes_accounted(d);
}

TEST(FrameDecoder, ResetClearsEverything) {
    FrameDecoder d;
    Bytes stream = test::encode(test::sample_orientation(), 1);
    stream.push_back(0x33);
    test::decode_stream(d, stream, 4096, false);
    d.reset();
    EXPECT_EQ(d.stats(), DecoderStats{});
    EXPECT_EQ(d.pending_bytes(), 0u);
    const auto events = test::decode_stream(d, test::encode(test::sample_orientation(), 9));
    ASSERT_EQ(events.size(), 1u);
    EXPECT_EQ(events[0].offset, 0u);
    EXPECT_EQ(events[0].lost_before, 0);
}

}  // namespace
}  // namespace glint::protocol
