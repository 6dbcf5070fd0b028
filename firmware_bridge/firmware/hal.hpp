// Hardware abstraction of the sensor board: the only seam between the portable firmware and a
// microcontroller (or the host simulation in sim/). Everything behind it is portable C++20 with
// no heap, no exceptions, no RTTI and no OS calls.
//
// The interfaces have protected non-virtual destructors: the firmware never owns or deletes a
// HAL object (no heap), and a virtual destructor would pull `operator delete` into the link.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

namespace glint::firmware {

// Result of one I2C transfer.
enum class I2cStatus : std::uint8_t {
    Ok = 0,
    Nack,      // no acknowledge: device absent, busy (e.g. booting) or in reset
    BusError,  // arbitration lost, stuck bus, timeout
};

// Register-oriented I2C master (7-bit addresses), as used by every sensor on the board.
class I2cBus {
public:
    // One write transaction: [addr+W] reg value [stop].
    virtual I2cStatus write_reg(std::uint8_t address, std::uint8_t reg, std::uint8_t value) = 0;
    // Write the start register, repeated start, read out.size() consecutive registers.
    virtual I2cStatus read_regs(std::uint8_t address, std::uint8_t first_reg,
                                std::span<std::uint8_t> out) = 0;

protected:
    ~I2cBus() = default;
};

// The serial link to the appliance. Both calls are non-blocking.
class Uart {
public:
    // Queues all of `bytes` for transmission, or nothing: returns false when the transmit buffer
    // cannot take the whole span (a frame is never sent in part, so the receiver never sees a
    // torn frame from the board).
    virtual bool write(std::span<const std::uint8_t> bytes) = 0;
    // Copies up to out.size() received bytes into `out`; returns how many (0 when none).
    virtual std::size_t read(std::span<std::uint8_t> out) = 0;

protected:
    ~Uart() = default;
};

// The board's monotonic clock: microseconds since reset, never wraps (PROTOCOL.md 3.1 shows how
// a 32-bit timer is extended).
class Clock {
public:
    virtual std::uint64_t now_us() = 0;
    // Idle until the clock reads at least `deadline_us`, or earlier when a byte arrives on the
    // UART (the main loop then polls again). A virtual clock jumps; hardware sleeps (WFI).
    virtual void wait_until_us(std::uint64_t deadline_us) = 0;

protected:
    ~Clock() = default;
};

// Digital I/O: the visitor buttons (raw, undebounced levels) and the status lamp.
class Gpio {
public:
    // True while button `id` is pressed (active level already resolved by the board code).
    virtual bool button_pressed(std::uint8_t id) = 0;
    virtual void set_lamp(bool on) = 0;

protected:
    ~Gpio() = default;
};

// Everything the firmware needs from a board.
struct Hal {
    I2cBus& i2c;
    Uart& uart;
    Clock& clock;
    Gpio& gpio;
};

}  // namespace glint::firmware
