// The simulator on a real pseudo-terminal, in-process: the sim loop runs in a thread (virtual
// clock, paced by the reader), the test opens the slave side like the appliance's serial driver,
// decodes frames and sends a HelloRequest back. Time-outs are short and only bound a failure.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <thread>

#include "firmware_bridge/firmware/sim/sensor_sim.hpp"
#include "firmware_test_support.hpp"

namespace glint::firmware::sim {
namespace {

namespace p = protocol;

class Fd {
public:
    explicit Fd(int fd) : fd_(fd) {}
    ~Fd() {
        if (fd_ >= 0) close(fd_);
    }
    Fd(const Fd&) = delete;
    Fd& operator=(const Fd&) = delete;
    int get() const { return fd_; }

private:
    int fd_;
};

// Reads from `fd` until `done` says so or 5 s pass (a failure bound, not a delay).
template <typename Done>
void read_frames(int fd, p::FrameDecoder& decoder, std::vector<p::FrameEvent>& events, Done done) {
    const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    std::array<std::uint8_t, 4096> buf{};
    while (!done() && std::chrono::steady_clock::now() < limit) {
        pollfd pfd{fd, POLLIN, 0};
        if (poll(&pfd, 1, 100) <= 0) continue;
        const ssize_t n = read(fd, buf.data(), buf.size());
        if (n <= 0) continue;
        decoder.feed_all(std::span<const std::uint8_t>(buf.data(), static_cast<std::size_t>(n)),
                         [&](const p::FrameEvent& e) { events.push_back(e); });
    }
}

TEST(SensorSimPty, FramesArriveOnTheSlaveAndRequestsAreAnswered) {
    SensorSimOptions options;
    options.pacing = Pacing::Fast;
    options.board.imu = ImuKind::Raw;
    options.trajectory = "yaw-sweep";
    options.pty_link = testing::TempDir() + "glint-sensor-sim-test-link";
    SensorSim sim(options);
    ASSERT_EQ(sim.port().rfind("/dev/pts/", 0), 0u) << sim.port();
    // The symlink points at the slave.
    std::array<char, 256> target{};
    const ssize_t len = readlink(options.pty_link.c_str(), target.data(), target.size() - 1);
    ASSERT_GT(len, 0);
    EXPECT_EQ(std::string(target.data(), static_cast<std::size_t>(len)), sim.port());

    Fd slave(open(options.pty_link.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC));
    ASSERT_GE(slave.get(), 0);
    std::atomic<bool> stop{false};
    std::thread loop([&] { sim.run(stop); });

    p::FrameDecoder decoder;
    std::vector<p::FrameEvent> events;
    const auto count = [&](p::MessageType type) {
        int n = 0;
        for (const auto& e : events) n += e.status == p::FrameStatus::Ok && e.message.type == type ? 1 : 0;
        return n;
    };
    read_frames(slave.get(), decoder, events, [&] { return count(p::MessageType::Orientation) >= 200; });
    ASSERT_GE(count(p::MessageType::Orientation), 200);
    ASSERT_FALSE(events.empty());
    EXPECT_EQ(events[0].message.type, p::MessageType::Hello);
    EXPECT_EQ(events[0].seq, 0);
    EXPECT_EQ(decoder.stats().crc_errors + decoder.stats().cobs_errors, 0u);
    EXPECT_EQ(decoder.stats().lost_frames, 0u);  // paced by this reader: nothing dropped

    // Appliance -> board through the pty: a HelloRequest is answered with a Hello.
    std::array<std::uint8_t, p::kMaxFrameSize> frame{};
    const p::EncodeResult r = p::encode_frame(p::HelloRequest{}, 0, frame);
    ASSERT_EQ(r.status, p::EncodeStatus::Ok);
    ASSERT_EQ(write(slave.get(), frame.data(), r.size), static_cast<ssize_t>(r.size));
    read_frames(slave.get(), decoder, events, [&] { return count(p::MessageType::Hello) >= 2; });
    stop = true;
    loop.join();
    EXPECT_EQ(count(p::MessageType::Hello), 2);
    EXPECT_EQ(sim.stats().rx_frames_ok, 1u);
    // The symlink goes away with the simulator.
}

TEST(SensorSimPty, SymlinkIsRemovedAndARegularFileIsNeverReplaced) {
    const std::string link = testing::TempDir() + "glint-sensor-sim-test-link2";
    {
        SensorSimOptions options;
        options.pty_link = link;
        SensorSim sim(options);
        struct stat st {};
        EXPECT_EQ(lstat(link.c_str(), &st), 0);
    }
    struct stat st {};
    EXPECT_NE(lstat(link.c_str(), &st), 0);

    { std::ofstream(link) << "precious"; }
    SensorSimOptions options;
    options.pty_link = link;
    try {
        SensorSim sim(options);
        ADD_FAILURE() << "replaced a regular file";
    } catch (const std::runtime_error& e) {
        EXPECT_EQ(std::string(e.what()), link + ": exists and is not a symlink; not replacing it");
    }
    std::ifstream in(link);
    std::string content;
    in >> content;
    EXPECT_EQ(content, "precious");
    std::remove(link.c_str());
}

}  // namespace
}  // namespace glint::firmware::sim
