// Host side of the I2C HAL: a bus with simulated chips attached at their addresses, and fault
// injection (every transfer to an address NACKed during a time window, like a loose connector).
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <span>
#include <vector>

#include "firmware_bridge/firmware/hal.hpp"

namespace glint::firmware::sim {

// A simulated chip: register transfers at a time of the board clock.
class I2cDevice {
public:
    virtual ~I2cDevice() = default;
    virtual I2cStatus write_reg(std::uint8_t reg, std::uint8_t value, std::uint64_t now_us) = 0;
    virtual I2cStatus read_regs(std::uint8_t first_reg, std::span<std::uint8_t> out,
                                std::uint64_t now_us) = 0;
};

// A chip model's answer to a burst read with auto-increment: out[i] is register first_reg + i of
// `registers`, and 0 past the end of the register map.
inline void read_register_file(std::span<const std::uint8_t> registers, std::uint8_t first_reg,
                               std::span<std::uint8_t> out) {
    for (std::size_t i = 0; i < out.size(); ++i) {
        const std::size_t reg = first_reg + i;
        out[i] = reg < registers.size() ? registers[reg] : 0;
    }
}

class SimI2cBus final : public I2cBus {
public:
    explicit SimI2cBus(Clock& clock) : clock_(clock) {}

    void attach(std::uint8_t address, I2cDevice& device) { devices_[address] = &device; }
    // Every transfer to `address` in [start_us, end_us) of the board clock is NACKed.
    void add_nack_window(std::uint8_t address, std::uint64_t start_us, std::uint64_t end_us) {
        windows_.push_back({address, start_us, end_us});
    }

    I2cStatus write_reg(std::uint8_t address, std::uint8_t reg, std::uint8_t value) override;
    I2cStatus read_regs(std::uint8_t address, std::uint8_t first_reg, std::span<std::uint8_t> out) override;

    std::uint64_t transfers() const { return transfers_; }
    std::uint64_t nacks() const { return nacks_; }

private:
    I2cDevice* device_at(std::uint8_t address, std::uint64_t now_us);

    struct Window {
        std::uint8_t address;
        std::uint64_t start_us;
        std::uint64_t end_us;
    };
    Clock& clock_;
    std::map<std::uint8_t, I2cDevice*> devices_;
    std::vector<Window> windows_;
    std::uint64_t transfers_ = 0;
    std::uint64_t nacks_ = 0;
};

}  // namespace glint::firmware::sim
