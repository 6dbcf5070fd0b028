// Shared helpers of the recording tests: a temporary directory, a small recording with every
// record kind written through the real Recorder, and file byte access.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "firmware_bridge/protocol/frame.hpp"
#include "firmware_bridge/protocol/frame_decoder.hpp"
#include "firmware_bridge/recording/reader.hpp"
#include "firmware_bridge/recording/recorder.hpp"

namespace glint::recording::test {

// A fresh directory under $TMPDIR, removed with everything in it at the end of the test.
class TempDir {
public:
    TempDir() {
        std::string tmpl = (std::filesystem::temp_directory_path() / "glint-recording-XXXXXX").string();
        if (mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
        path_ = tmpl;
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    std::string file(const std::string& name) const { return (path_ / name).string(); }

private:
    std::filesystem::path path_;
};

inline Bytes read_file(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline void write_file(const std::string& path, std::span<const std::uint8_t> bytes) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
}

inline FileHeader sample_header() {
    FileHeader h;
    h.created_unix_us = 1'700'000'000'123'456;
    h.created_monotonic_us = 5'000'000;
    h.transport = Transport::Serial;
    h.baud = 230400;
    h.device = "/dev/ttyACM0";
    h.decoded_types = board_message_types();
    h.notes = {{"board", "rev B"}, {"operator", "test"}, {"empty", ""}};
    return h;
}

inline Bytes encode(const protocol::Message& m, std::uint16_t seq) {
    std::array<std::uint8_t, protocol::kMaxFrameSize> buf{};
    const auto r = protocol::encode_frame(m, seq, buf);
    EXPECT_EQ(r.status, protocol::EncodeStatus::Ok);
    return Bytes(buf.begin(), buf.begin() + r.size);
}

// Writes a small recording as a host driver would (bytes, then the decoder's Ok messages),
// with a marker, a GPIO edge, a sent chunk and a stream restart; returns the record bodies the
// file holds, in order.
inline std::vector<RecordBody> write_small_recording(const std::string& path, Clock& clock) {
    RecorderOptions options;
    options.header = sample_header();
    Recorder recorder(path, options, clock);
    std::vector<RecordBody> expected;
    Bytes stream;
    stream.push_back(0x00);  // the board's idle delimiter after reset
    const Bytes hello = encode(protocol::Hello{1, 0, 1, 2, 3, 0xABCD, 0x3F, 2}, 0);
    stream.insert(stream.end(), hello.begin(), hello.end());
    for (std::uint16_t i = 1; i <= 6; ++i) {
        const Bytes f = encode(protocol::Orientation{1'000'000u + i * 10'000u, protocol::kQ30One, 0, 0, 0}, i);
        stream.insert(stream.end(), f.begin(), f.end());
    }
    // Garbage that the decoder rejects (no record but the raw bytes).
    stream.insert(stream.end(), {0x13, 0x37, 0x00});

    auto decoder = std::make_unique<protocol::FrameDecoder>();
    std::uint64_t t = 10'000'000, offset = 0;
    recorder.mark(t - 5, "capture started");
    expected.push_back(MarkerRecord{t - 5, "capture started"});
    const std::size_t cuts[] = {1, 20, 33, 60, 61, 120, 200, stream.size()};
    std::size_t begin = 0;
    for (const std::size_t end : cuts) {
        const std::size_t e = std::min(end, stream.size());
        if (e <= begin) continue;
        const Bytes chunk(stream.begin() + static_cast<std::ptrdiff_t>(begin), stream.begin() + static_cast<std::ptrdiff_t>(e));
        t += 1'500;
        EXPECT_TRUE(recorder.on_bytes(t, chunk));
        expected.push_back(RawBytesRecord{t, offset, Direction::Received, chunk});
        offset += chunk.size();
        decoder->feed_all(chunk, [&](const protocol::FrameEvent& ev) {
            EXPECT_TRUE(recorder.on_sample(t, ev));
            if (ev.status == protocol::FrameStatus::Ok)
                expected.push_back(DecodedMessageRecord{t, ev.offset, ev.seq, ev.message});
        });
        begin = e;
    }
    const Bytes request = encode(protocol::HelloRequest{}, 0);
    recorder.on_bytes(t + 10, request, Direction::Sent);
    expected.push_back(RawBytesRecord{t + 10, 0, Direction::Sent, request});
    recorder.on_gpio(t + 20, 17, Edge::Rising, "gpiochip0");
    expected.push_back(GpioEventRecord{t + 20, 17, Edge::Rising, "gpiochip0"});
    recorder.on_stream_restart(t + 30, "port reopened");
    expected.push_back(StreamRestartRecord{t + 30, "port reopened"});
    const Bytes again = encode(protocol::Hello{1, 0, 1, 2, 3, 0xABCD, 0x3F, 2}, 0);
    recorder.on_bytes(t + 40, again);
    expected.push_back(RawBytesRecord{t + 40, 0, Direction::Received, again});
    decoder->reset();
    decoder->feed_all(again, [&](const protocol::FrameEvent& ev) {
        recorder.on_sample(t + 40, ev);
        expected.push_back(DecodedMessageRecord{t + 40, ev.offset, ev.seq, ev.message});
    });
    recorder.mark(t + 50, "capture stopped");
    expected.push_back(MarkerRecord{t + 50, "capture stopped"});
    EXPECT_TRUE(recorder.close()) << recorder.error();
    return expected;
}

inline std::vector<Record> read_all(RecordingReader& reader) {
    std::vector<Record> out;
    while (auto r = reader.next()) out.push_back(std::move(*r));
    return out;
}

}  // namespace glint::recording::test
