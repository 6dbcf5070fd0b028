// A recorded sensor file (firmware_bridge/recording) as an orientation source: the recorded raw
// bytes go through the same decode path as the live serial driver (board_stream.hpp), so a
// replay exercises the real parsing, clock mapping and health code byte for byte. A file of a
// source without a byte stream (I2C, Modbus: FORMAT.md 3.2) holds the samples its driver
// published, and those are published again (sample_recording.hpp).
//
// Time: samples keep the recorded appliance times (the clock of the session they came from), so
// they line up with that session's camera frames. The replay is paced on its own clock, shifted
// so that its "now" equals the recorded time being replayed: Pacing::Fast runs on a virtual clock
// (as fast as possible, deterministic), Pacing::Realtime at recorded speed.
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <thread>

#include "firmware_bridge/host/board_stream.hpp"
#include "firmware_bridge/host/orientation_source.hpp"
#include "firmware_bridge/recording/reader.hpp"

namespace glint::host {

enum class ReplayPacing { Fast, Realtime };

namespace detail {
// A clock whose "now" is another clock's plus a fixed offset (set once the first record's time
// is known): the replay's timeline is the recording's.
class ShiftedClock final : public recording::Clock {
public:
    explicit ShiftedClock(ReplayPacing pacing);
    std::uint64_t now_us() override { return inner().now_us() + offset_us_; }
    void sleep_until_us(std::uint64_t t_us) override {
        inner().sleep_until_us(t_us > offset_us_ ? t_us - offset_us_ : 0);
    }
    void align(std::uint64_t recorded_us) { offset_us_ = recorded_us - inner().now_us(); }

private:
    recording::Clock& inner() { return virtual_ ? static_cast<recording::Clock&>(*virtual_) : *steady_; }
    std::unique_ptr<recording::VirtualClock> virtual_;
    std::unique_ptr<recording::SteadyClock> steady_;
    std::uint64_t offset_us_ = 0;
};
struct ReplayClockHolder {
    explicit ReplayClockHolder(ReplayPacing pacing) : replay_clock(pacing) {}
    ShiftedClock replay_clock;
};
}  // namespace detail

class ReplaySource final : private detail::ReplayClockHolder, public OrientationSource {
public:
    // Opens the file (throws SourceError naming it when it cannot be read as a recording).
    ReplaySource(std::string name, const std::string& path, ReplayPacing pacing = ReplayPacing::Fast,
                 SourceOptions options = {});
    ~ReplaySource() override;

    void start() override;  // replays on a thread
    void stop() override;
    // Replays the whole file on the calling thread (for offline tools); returns when done.
    void run_to_end();
    bool finished() const { return finished_; }

    void set_message_sink(BoardStream::MessageSink sink) { message_sink_ = std::move(sink); }
    BoardStatus board_status() const;
    // Damage found in the file (byte offsets), as the reader reported it.
    std::vector<recording::ReadIssue> file_issues() const;

private:
    void replay();

    std::unique_ptr<recording::RecordingReader> reader_;
    BoardStream::MessageSink message_sink_;
    std::thread thread_;
    std::atomic<bool> stopping_{false};
    std::atomic<bool> finished_{false};
    mutable std::mutex mutex_;
    BoardStatus status_;
    std::vector<recording::ReadIssue> issues_;
};

}  // namespace glint::host
