// Seeded fuzz loop: thousands of frames with garbage between and inside them. Every intact frame
// (unchanged and preceded by a delimiter) is decoded exactly once at its offset; nothing else is
// accepted; lost frames match the sequence gaps; every byte is accounted for.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>
#include <random>

#include "protocol_test_support.hpp"

namespace glint::protocol {
namespace {

using test::Bytes;

// std::mt19937 yields unsigned long on LP64; this wrapper yields exactly 32 bits (-Wconversion).
struct Rng {
    using result_type = std::uint32_t;
    explicit Rng(std::uint32_t seed) : engine(seed) {}
    static constexpr result_type min() { return 0; }
    static constexpr result_type max() { return UINT32_MAX; }
    result_type operator()() { return static_cast<result_type>(engine()); }
    std::mt19937 engine;
};

// A random valid message of any type except Hello (a Hello with seq 0 would restart tracking).
Message random_message(Rng& rng) {
    auto i32 = [&] { return static_cast<std::int32_t>(rng()); };
    auto u8 = [&] { return static_cast<std::uint8_t>(rng()); };
    const std::uint64_t t = (static_cast<std::uint64_t>(rng()) << 32) | rng();
    switch (rng() % 10) {
        case 0: {
            // A random unit quaternion (normalised Gaussian 4-vector).
            std::normal_distribution<double> g;
            double q[4];
            double n2 = 0;
            for (double& c : q) { c = g(rng); n2 += c * c; }
            const double n = std::sqrt(n2);
            return Orientation{t, to_q30(q[0] / n), to_q30(q[1] / n), to_q30(q[2] / n), to_q30(q[3] / n)};
        }
        case 1: return RawImu{t, {i32(), i32(), i32()}, {i32(), i32(), i32()}, {i32(), i32(), i32()}, u8()};
        case 2:
            return FusionStatus{t, static_cast<FusionMode>(rng() % 3), static_cast<std::uint8_t>(rng() % 4),
                                static_cast<std::uint8_t>(rng() % 4), static_cast<std::uint8_t>(rng() % 4),
                                static_cast<std::uint8_t>(rng() % 4), {i32(), i32(), i32()}};
        case 3: return ButtonEvent{t, u8(), static_cast<ButtonState>(rng() % 2)};
        case 4: return Heartbeat{t, rng(), rng(), rng(), rng(), rng()};
        case 5: return ErrorReport{t, static_cast<std::uint16_t>(rng()), rng()};
        case 6:
            return ConfigAck{static_cast<std::uint16_t>(rng()), static_cast<std::uint16_t>(rng()),
                             static_cast<ConfigStatus>(rng() % 4), ConfigValue::from_u32(rng())};
        case 7: return HelloRequest{};
        case 8: return ConfigGet{static_cast<std::uint16_t>(rng())};
        default: return ConfigSet{static_cast<std::uint16_t>(rng()), ConfigValue::from_bool(rng() % 2)};
    }
}

struct SentFrame {
    std::uint64_t offset = 0;  // where its bytes start in the stream
    Message message;
    std::uint16_t seq = 0;
    Bytes original;            // the frame as encoded, before any damage
    bool intact = false;       // arrived unchanged and preceded by a delimiter (or the stream start)
};

Bytes random_garbage(Rng& rng) {
    // Now and then a long run (a burst of line noise) that makes an oversize frame.
    Bytes g(rng() % 50 == 0 ? 300 + rng() % 400 : 1 + rng() % 40);
    // Mix of zero-rich and zero-free garbage: both splitting and merging frames must be handled.
    const bool zeros = rng() % 2;
    for (auto& b : g) b = static_cast<std::uint8_t>(zeros ? rng() % 4 : 1 + rng() % 255);
    return g;
}

void run_garbage_stream(std::uint32_t seed) {
    constexpr int kFrames = 4000;
    Rng rng(seed);
    Bytes stream;
    std::vector<SentFrame> sent;
    std::uint16_t seq = 65000;  // crosses the 65535 -> 0 wrap
    int corrupted = 0;
    for (int i = 0; i < kFrames; ++i) {
        SentFrame f;
        f.message = random_message(rng);
        f.seq = seq++;
        const Bytes original = test::encode(f.message, f.seq);
        Bytes frame = original;
        const unsigned dice = rng() % 100;
        bool changed = false;
        if (dice < 10) {  // flip 1..3 bytes anywhere, the delimiter included
            for (unsigned k = 0, n = 1 + rng() % 3; k < n; ++k) {
                frame[rng() % frame.size()] ^= static_cast<std::uint8_t>(1 + rng() % 255);
            }
            changed = true;
        } else if (dice < 14) {  // garbage inserted inside the frame
            const Bytes g = random_garbage(rng);
            // Strictly inside: after the first byte, at the latest just before the delimiter.
            frame.insert(frame.begin() + 1 + static_cast<long>(rng() % (frame.size() - 1)), g.begin(), g.end());
            changed = true;
        } else if (dice < 17) {  // bytes lost inside the frame
            const std::size_t at = rng() % frame.size();
            frame.erase(frame.begin() + static_cast<long>(at),
                        frame.begin() + static_cast<long>(std::min(frame.size(), at + 1 + rng() % 5)));
            changed = true;
        } else if (dice < 19) {  // the whole frame lost
            continue;
        }
        if (changed) ++corrupted;
        f.offset = stream.size();
        f.original = original;
        test::append(stream, frame);
        sent.push_back(f);
        if (rng() % 100 < 15) test::append(stream, random_garbage(rng));  // garbage between frames
    }

    // Intact is judged on the final stream, not on what was done to a frame: two flips of one
    // byte may cancel, and garbage that starts with 0x00 inserted just before a delimiter leaves
    // the frame whole. A frame is intact when its bytes arrive unchanged between two delimiters.
    for (SentFrame& f : sent) {
        const std::size_t n = f.original.size();
        f.intact = (f.offset == 0 || stream[f.offset - 1] == 0x00) && f.offset + n <= stream.size() &&
                   std::equal(f.original.begin(), f.original.end(), stream.begin() + static_cast<long>(f.offset));
    }

    FrameDecoder decoder;
    // Odd chunk sizes, as a serial driver would deliver them.
    std::vector<FrameEvent> events;
    std::span<const std::uint8_t> rest(stream);
    while (!rest.empty()) {
        const std::size_t n = std::min<std::size_t>(1 + rng() % 97, rest.size());
        decoder.feed_all(rest.first(n), [&](const FrameEvent& e) { events.push_back(e); });
        rest = rest.subspan(n);
    }
    FrameEvent tail;
    if (decoder.finish(tail)) events.push_back(tail);

    std::map<std::uint64_t, const FrameEvent*> ok_by_offset;
    for (const FrameEvent& e : events) {
        if (e.status == FrameStatus::Ok) ok_by_offset[e.offset] = &e;
    }
    std::size_t intact = 0;
    std::size_t first_ok_index = sent.size(), last_ok_index = 0, ok_frames = 0;
    for (std::size_t i = 0; i < sent.size(); ++i) {
        const SentFrame& f = sent[i];
        const auto it = ok_by_offset.find(f.offset);
        if (f.intact) {
            ++intact;
            ASSERT_NE(it, ok_by_offset.end()) << "intact frame " << i << " at offset " << f.offset << " not decoded";
            EXPECT_TRUE(it->second->message == f.message) << "frame " << i;
            EXPECT_EQ(it->second->seq, f.seq) << "frame " << i;
        }
        if (it != ok_by_offset.end()) {
            ++ok_frames;
            first_ok_index = std::min(first_ok_index, i);
            last_ok_index = i;
        }
    }
    // Accepted frames that do not start where an intact frame starts would be CRC-32C collisions
    // (or garbage that happens to be a valid frame). Expected count: corrupted * 2^-32 ~ 1e-7.
    std::size_t collisions = 0;
    for (const auto& [offset, e] : ok_by_offset) {
        const bool is_sent_intact = std::any_of(sent.begin(), sent.end(),
                                                [&](const SentFrame& f) { return f.intact && f.offset == offset; });
        if (!is_sent_intact) {
            ++collisions;
            const auto f = std::find_if(sent.begin(), sent.end(), [&](const SentFrame& x) { return x.offset >= offset; });
            std::cout << "accepted at " << offset << " size " << e->size << " type " << int(e->type) << " seq " << e->seq
                      << " next sent at " << (f == sent.end() ? 0 : f->offset) << " seq " << (f == sent.end() ? 0 : f->seq)
                      << " bytes " << test::hex(std::span<const std::uint8_t>(stream).subspan(offset, e->size)) << "\n";
        }
    }
    EXPECT_EQ(collisions, 0u);
    EXPECT_EQ(ok_by_offset.size(), intact);
    EXPECT_EQ(decoder.stats().frames_ok, intact);
    EXPECT_GT(corrupted, kFrames / 10);  // the test really exercised corruption
    EXPECT_GT(intact, static_cast<std::size_t>(kFrames) * 6 / 10);

    // Lost frames: every sent-and-numbered frame between the first and last accepted ones that was
    // not accepted, plus the frames dropped whole (their numbers are missing too).
    const std::uint16_t first_seq = sent[first_ok_index].seq, last_seq = sent[last_ok_index].seq;
    const std::size_t numbered = static_cast<std::uint16_t>(last_seq - first_seq) + 1u;
    EXPECT_EQ(decoder.stats().lost_frames, numbered - ok_frames);

    const DecoderStats& s = decoder.stats();
    EXPECT_EQ(s.bytes_in, stream.size());
    test::expect_bytes_accounted(decoder);
    EXPECT_EQ(s.unknown_types + s.bad_lengths + s.bad_values + s.version_mismatches, 0u);
    std::cout << "frames sent " << sent.size() << ", intact " << intact << ", corrupted " << corrupted
              << ", ok " << s.frames_ok << ", crc " << s.crc_errors << ", cobs " << s.cobs_errors
              << ", short " << s.too_short << ", oversize " << s.oversize_frames << ", lost " << s.lost_frames
              << ", discarded bytes " << s.bytes_discarded << " of " << s.bytes_in << "\n";
}

TEST(GarbageStream, EveryIntactFrameDecodedExactlyAndNothingCorruptAccepted) {
    // Fixed seeds: every run is reproducible; several, so more damage patterns are covered.
    for (const std::uint32_t seed : {0x61696E74u, 1u, 2u, 3u, 4u}) {
        SCOPED_TRACE(seed);
        run_garbage_stream(seed);
    }
}

}  // namespace
}  // namespace glint::protocol
