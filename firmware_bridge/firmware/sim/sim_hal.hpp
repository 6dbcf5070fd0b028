// Host implementations of the HAL besides the I2C bus (sim_i2c_bus.hpp): a virtual clock (tests,
// --fast), the real monotonic clock (--realtime), a UART in memory (tests), a UART on a
// pseudo-terminal (the sim tool: the appliance's serial driver opens the slave side), and GPIO
// with scripted, bouncing button presses.
#pragma once

#include <cstdint>
#include <deque>
#include <span>
#include <string>
#include <vector>

#include "firmware_bridge/firmware/hal.hpp"

namespace glint::firmware::sim {

// Time only moves when the simulation moves it: wait_until_us jumps to the deadline.
class VirtualClock final : public Clock {
public:
    explicit VirtualClock(std::uint64_t start_us = 0) : now_us_(start_us) {}
    std::uint64_t now_us() override { return now_us_; }
    void wait_until_us(std::uint64_t deadline_us) override {
        if (deadline_us > now_us_) now_us_ = deadline_us;
    }
    void advance_us(std::uint64_t us) { now_us_ += us; }

private:
    std::uint64_t now_us_;
};

// CLOCK_MONOTONIC since construction. wait_until_us sleeps, waking early when `wake_fd`
// (e.g. the pty master) becomes readable.
class RealtimeClock final : public Clock {
public:
    explicit RealtimeClock(int wake_fd = -1);
    std::uint64_t now_us() override;
    void wait_until_us(std::uint64_t deadline_us) override;

private:
    std::uint64_t start_ns_;
    int wake_fd_;
};

// UART backed by memory: what the firmware writes is appended to `sent`, `inject` queues bytes
// for it to read. An optional capacity limits the bytes not yet taken by the test, so transmit
// overflow can be tested.
class MemoryUart final : public Uart {
public:
    bool write(std::span<const std::uint8_t> bytes) override;
    std::size_t read(std::span<std::uint8_t> out) override;

    void inject(std::span<const std::uint8_t> bytes) { rx_.insert(rx_.end(), bytes.begin(), bytes.end()); }
    // Bytes written since the last take (and forgets them).
    std::vector<std::uint8_t> take();
    void set_capacity(std::size_t bytes) { capacity_ = bytes; }

    std::vector<std::uint8_t> sent;

private:
    std::deque<std::uint8_t> rx_;
    std::size_t capacity_ = SIZE_MAX;
};

// A UART on a file descriptor (a pty master or a serial device), non-blocking: frames wait in a
// user-space transmit buffer when the descriptor is full; when that is full too, write() refuses
// them (the firmware counts a dropped frame).
class FdUart : public Uart {
public:
    FdUart(const FdUart&) = delete;
    FdUart& operator=(const FdUart&) = delete;
    virtual ~FdUart() = default;

    bool write(std::span<const std::uint8_t> bytes) override;
    std::size_t read(std::span<std::uint8_t> out) override;

    int fd() const { return fd_; }
    // What a reader opens: the pty slave or the device itself.
    virtual const std::string& port() const = 0;
    // Moves buffered bytes into the descriptor; returns the bytes still waiting.
    std::size_t flush();
    std::size_t pending() const { return tx_.size(); }
    // Waits up to timeout_ms for the descriptor to take more bytes; true when it drained some.
    bool wait_drain(int timeout_ms);

protected:
    explicit FdUart(std::size_t tx_buffer_bytes) : tx_capacity_(tx_buffer_bytes) {}
    int fd_ = -1;

private:
    std::deque<std::uint8_t> tx_;
    std::size_t tx_capacity_;
};

// UART on a pseudo-terminal (openpty). The firmware talks to the master side; the slave is set
// raw (cfmakeraw) and kept open by the simulator, so a client may open, close and reopen it
// (e.g. /dev/pts/7, or the symlink `link_path`) without hanging up the link.
class PtyUart final : public FdUart {
public:
    // Throws std::system_error when no pty can be opened, std::runtime_error when `link_path`
    // exists and is not a symlink (it is never overwritten).
    explicit PtyUart(std::string link_path = {}, std::size_t tx_buffer_bytes = 16384);
    ~PtyUart() override;

    const std::string& port() const override { return slave_path_; }
    const std::string& slave_path() const { return slave_path_; }
    const std::string& link_path() const { return link_path_; }
    int master_fd() const { return fd_; }

private:
    int slave_ = -1;
    std::string slave_path_;
    std::string link_path_;
};

// UART on a real serial device (a USB-serial adapter wired to the appliance, or one end of a
// socat pair): termios raw, 8N1, at `baud`. Throws std::system_error naming the device.
class SerialDeviceUart final : public FdUart {
public:
    SerialDeviceUart(std::string path, int baud, std::size_t tx_buffer_bytes = 16384);
    ~SerialDeviceUart() override;
    const std::string& port() const override { return path_; }

private:
    std::string path_;
};

// One scripted press: held from start_us to end_us (board clock), with contact bounce (the level
// toggles every millisecond for bounce_us after each edge).
struct ButtonPress {
    std::uint8_t button = 0;
    std::uint64_t start_us = 0;
    std::uint64_t end_us = 0;
    std::uint64_t bounce_us = 3000;
};

class SimGpio final : public Gpio {
public:
    explicit SimGpio(Clock& clock) : clock_(clock) {}
    void add_press(ButtonPress press) { presses_.push_back(press); }
    bool button_pressed(std::uint8_t id) override;
    void set_lamp(bool on) override;

    bool lamp() const { return lamp_; }
    std::uint32_t lamp_changes() const { return lamp_changes_; }

private:
    Clock& clock_;
    std::vector<ButtonPress> presses_;
    bool lamp_ = false;
    std::uint32_t lamp_changes_ = 0;
};

}  // namespace glint::firmware::sim
