// A pseudo-terminal pair that plays the sensor board: the test writes protocol frames (or
// garbage) on the master, the driver under test opens the slave through a symlink that can be
// re-pointed at a new pty (unplug and replug).
#pragma once

#include <fcntl.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "firmware_bridge/firmware/rotation.hpp"
#include "firmware_bridge/host/orientation_source.hpp"
#include "firmware_bridge/protocol/frame.hpp"
#include "firmware_bridge/protocol/messages.hpp"

namespace glint::host::test {

class FakeBoardPort {
public:
    explicit FakeBoardPort(std::filesystem::path link) : link_(std::move(link)) { plug(); }
    ~FakeBoardPort() { unplug(); std::filesystem::remove(link_); }

    // A new pty behind the link (the old one, if any, is closed: the reader sees a hang-up).
    void plug() {
        unplug();
        int slave = -1;
        char name[256] = {};
        if (openpty(&master_, &slave, name, nullptr, nullptr) != 0) throw std::runtime_error("openpty failed");
        termios t{};
        tcgetattr(slave, &t);
        cfmakeraw(&t);
        tcsetattr(slave, TCSANOW, &t);
        slave_ = slave;  // held open like the simulator does, so nothing written is lost before the driver opens it
        std::filesystem::remove(link_);
        std::filesystem::create_symlink(name, link_);
    }
    void unplug() {
        if (master_ >= 0) ::close(master_);
        if (slave_ >= 0) ::close(slave_);
        master_ = slave_ = -1;
    }
    void write_bytes(const std::vector<std::uint8_t>& b) {
        std::size_t done = 0;
        while (done < b.size()) {
            const ssize_t n = ::write(master_, b.data() + done, b.size() - done);
            if (n <= 0) throw std::runtime_error("pty write failed");
            done += std::size_t(n);
        }
    }
    // One orientation frame; returns the bytes it wrote (to corrupt copies of them). Sent frames
    // are paced 1 ms apart: a board streams, and a backlog written all at once cannot be timed
    // (BoardStream drops its untimed samples; tested separately).
    std::vector<std::uint8_t> orientation(std::uint64_t board_us, firmware::Quatd q, std::uint16_t seq,
                                          bool send = true) {
        protocol::Orientation o{board_us, protocol::to_q30(q.w), protocol::to_q30(q.x), protocol::to_q30(q.y),
                                protocol::to_q30(q.z)};
        std::uint8_t buf[protocol::kMaxFrameSize];
        const protocol::EncodeResult r = protocol::encode_frame(protocol::Message(o), seq, buf);
        std::vector<std::uint8_t> bytes(buf, buf + r.size);
        if (send) {
            write_bytes(bytes);
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        return bytes;
    }
    const std::filesystem::path& link() const { return link_; }
    // A board clock that runs with real time (µs since this port was made), as a real board's.
    std::uint64_t board_now_us() const {
        return std::uint64_t(std::chrono::duration_cast<std::chrono::microseconds>(
                                 std::chrono::steady_clock::now() - born_)
                                 .count());
    }

private:
    std::filesystem::path link_;
    int master_ = -1;
    int slave_ = -1;
    std::chrono::steady_clock::time_point born_ = std::chrono::steady_clock::now();
};

// Waits (up to `limit`) until pred() holds; returns whether it did.
template <typename Pred>
bool eventually(Pred pred, std::chrono::milliseconds limit = std::chrono::milliseconds(3000)) {
    const auto end = std::chrono::steady_clock::now() + limit;
    while (std::chrono::steady_clock::now() < end) {
        if (pred()) return true;
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    return pred();
}

inline firmware::Quatd yaw(double rad) { return firmware::Quatd::from_axis_angle({0, 1, 0}, rad); }

// The samples a source published, gathered from its reader thread.
struct Collector {
    std::mutex m;
    std::vector<OrientationSample> samples;
    void add(const OrientationSample& x) {
        const std::lock_guard lock(m);
        samples.push_back(x);
    }
    void attach(OrientationSource& s) {
        s.set_sample_callback([this](const OrientationSample& x) { add(x); });
    }
    std::size_t count() {
        const std::lock_guard lock(m);
        return samples.size();
    }
    OrientationSample last() {
        const std::lock_guard lock(m);
        return samples.back();
    }
};

}  // namespace glint::host::test
