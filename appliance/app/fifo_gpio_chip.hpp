// A GPIO chip for tests of the whole program (`[gpio] chip = "fifo:PATH"`), beside the real
// libgpiod chip: edges come from lines "LINE LEVEL" (0 or 1, the raw level before active-low)
// written into the named pipe PATH, and every output change is appended to PATH.out as
// "T_NS LINE LEVEL". The test plays the technician turning the key switch and watches the lamp.
#pragma once

#include <atomic>
#include <filesystem>
#include <fstream>
#include <memory>
#include <thread>

#include "firmware_bridge/host/gpio_lines.hpp"

namespace glint::app {

class FifoGpioChip final : public host::GpioChip {
public:
    // Throws InputError naming the pipe when it is not a FIFO.
    FifoGpioChip(const std::filesystem::path& fifo, recording::Clock& clock);
    ~FifoGpioChip() override;
    std::string name() const override { return "fifo:" + fifo_.string(); }
    void request_inputs(const std::vector<unsigned>& lines, bool active_low) override { chip_.request_inputs(lines, active_low); }
    void request_outputs(const std::vector<unsigned>& lines) override { chip_.request_outputs(lines); }
    std::optional<host::GpioEdge> wait_edge(std::chrono::milliseconds timeout) override { return chip_.wait_edge(timeout); }
    void set_output(unsigned line, bool high) override;

private:
    std::filesystem::path fifo_;
    recording::Clock& clock_;
    host::FakeGpioChip chip_;
    std::ofstream outputs_;
    int fd_ = -1;
    std::atomic<bool> stopping_{false};
    std::thread reader_;
};

}  // namespace glint::app
