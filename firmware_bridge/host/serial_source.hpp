// The sensor board on a serial port (USB CDC-ACM, a UART, or a pseudo-terminal in tests):
// termios raw mode at the configured baud rate, a reader thread, the shared decode path
// (board_stream.hpp), and the faults of a real cable:
// - garbage and damaged frames: the decoder resynchronises; counted in crc/frame errors;
// - lost frames: sequence gaps, counted;
// - a stalled board: no sample for longer than the stall limit (200 ms by default) shows as
//   Stalled within that limit plus one poll period (20 ms);
// - unplug and replug: EOF, EIO/ENXIO, POLLHUP, or the device node now naming another device
//   (checked every 250 ms): the port is closed, the state is Disconnected, and it is reopened
//   with back-off (50 ms doubling to 1 s); every reopen counts as a reconnect and restarts the
//   decoder and the clock estimate (it may be another board).
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <thread>

#include "firmware_bridge/host/board_stream.hpp"
#include "firmware_bridge/host/orientation_source.hpp"

namespace glint::host {

struct SerialOptions {
    std::string path;          // /dev/ttyACM0, /dev/serial/by-id/..., a pty or a symlink to one
    int baud = 115200;         // a standard rate (serial_baud_supported)
    int poll_ms = 20;          // longest wait in the reader loop
    int backoff_min_ms = 50;   // first wait before reopening
    int backoff_max_ms = 1000;
};

bool serial_baud_supported(int baud);

class SerialSource final : public OrientationSource {
public:
    // Throws SourceError for an unsupported baud rate or an empty path.
    SerialSource(std::string name, SerialOptions options, recording::Clock& clock, SourceOptions source_options = {});
    ~SerialSource() override;

    // Must be called before start(); the recorder must outlive the source (or stop() first).
    void set_recorder(recording::Recorder* recorder) { recorder_ = recorder; }
    void set_message_sink(BoardStream::MessageSink sink) { message_sink_ = std::move(sink); }
    // The board's debounced button edges only (the kiosk's visitor button may be wired to the
    // board): host time of arrival, the board's button number, pressed or released. Replaces any
    // message sink. Before start().
    void set_button_sink(std::function<void(std::int64_t host_ns, unsigned button, bool pressed)> sink) {
        set_message_sink([sink = std::move(sink)](std::int64_t host_ns, const protocol::Message& m) {
            if (m.type == protocol::MessageType::ButtonEvent)
                sink(host_ns, m.button_event.button_id, m.button_event.state == protocol::ButtonState::Pressed);
        });
    }

    void start() override;
    void stop() override;

    BoardStatus board_status() const;

private:
    void run();
    bool open_port();
    void close_port(const std::string& why);
    void wait_interruptible(int ms);
    void sync_health();

    SerialOptions options_;
    recording::Recorder* recorder_ = nullptr;
    BoardStream::MessageSink message_sink_;
    std::unique_ptr<BoardStream> stream_;
    std::thread thread_;
    int fd_ = -1;
    int wake_fd_ = -1;  // eventfd: stop() wakes the reader's poll
    std::uint64_t device_id_ = 0;  // st_rdev of the open port
    std::atomic<bool> stopping_{false};
    bool ever_opened_ = false;
    mutable std::mutex status_mutex_;
    BoardStatus status_copy_;
};

}  // namespace glint::host
