// The appliance-side BNO055 over I2C: the firmware's driver on the appliance, against the
// simulator's register-level chip model on a simulated bus (the fake beside the real i2c-dev bus),
// on one virtual timeline.
#include <gtest/gtest.h>

#include <algorithm>

#include "appliance/core/rotation.hpp"
#include "firmware_bridge/firmware/sim/bno055_model.hpp"
#include "firmware_bridge/firmware/sim/imu_physics.hpp"
#include "firmware_bridge/firmware/sim/sim_i2c_bus.hpp"
#include "firmware_bridge/host/i2c_bno055_source.hpp"

namespace glint::host {
namespace {

namespace sim = firmware::sim;

// The firmware HAL's clock on the appliance's (virtual) clock: the chip model and the driver
// share one timeline.
class ClockAdapter final : public firmware::Clock {
public:
    explicit ClockAdapter(recording::Clock& c) : c_(c) {}
    std::uint64_t now_us() override { return c_.now_us(); }
    void wait_until_us(std::uint64_t t) override { c_.sleep_until_us(t); }

private:
    recording::Clock& c_;
};

struct Rig {
    sim::Trajectory truth = sim::Trajectory::builtin("yaw-sweep");
    sim::ImuPhysics physics{truth, sim::SensorErrors::none(), 1};
    recording::VirtualClock clock{0};
    ClockAdapter board_clock{clock};
    sim::SimI2cBus bus{board_clock};
    sim::Bno055Model chip{physics, {}};
    std::vector<OrientationSample> samples;
    std::unique_ptr<I2cBno055Source> source;
    Rig() {
        bus.attach(0x28, chip);
        I2cBno055Options o;
        source = std::make_unique<I2cBno055Source>("i2c:sim", bus, o, clock);
        source->set_sample_callback([this](const OrientationSample& s) { samples.push_back(s); });
    }
    double worst_error_deg(std::int64_t from_ns) const {
        double worst = 0;
        for (const OrientationSample& s : samples)
            if (s.t_ns >= from_ns) {
                const glm::dquat t = to_glm(truth.at(std::uint64_t(s.t_ns / 1000)).world_from_sensor);
                worst = std::max(worst, angle_between(s.world_from_sensor, t));
            }
        return worst * 180.0 / 3.14159265358979;
    }
};

TEST(I2cBno055, ReadsTheChipsOrientationInTheWorldFrame) {
    Rig r;
    r.source->run_until(3'000'000);
    // Silent for its 650 ms boot, then the mode switch to NDOF, then 100 Hz.
    ASSERT_GT(r.samples.size(), 200u);
    EXPECT_LT(r.samples.size(), 301u);
    EXPECT_LT(r.worst_error_deg(0), 0.1);
    const LinkHealth h = r.source->health();
    EXPECT_EQ(h.reconnects, 0u);
    EXPECT_NEAR(h.rate_hz, 100.0, 1.0);
}

TEST(I2cBno055, ANackRunIsCountedAndRecovered) {
    Rig r;
    r.bus.add_nack_window(0x28, 1'500'000, 1'800'000);  // 300 ms of silence on the bus
    r.source->run_until(1'700'000);
    LinkHealth h = r.source->health();
    EXPECT_GT(h.timeouts, 0u);
    EXPECT_EQ(h.state, LinkState::Disconnected);
    EXPECT_NE(h.last_error.find("0x28"), std::string::npos) << h.last_error;
    const std::size_t before = r.samples.size();
    r.source->run_until(3'000'000);
    h = r.source->health();
    EXPECT_GE(h.reconnects, 1u);
    EXPECT_EQ(h.state, LinkState::Streaming);
    EXPECT_GT(r.samples.size(), before + 50);
    EXPECT_LT(r.worst_error_deg(2'500'000'000), 0.1);
}

TEST(I2cBno055, AChipResetIsProbedAgain) {
    Rig r;
    r.source->run_until(1'500'000);
    r.chip.reset(r.clock.now_us());  // brown-out: reboots into CONFIGMODE
    r.source->run_until(4'000'000);
    const LinkHealth h = r.source->health();
    EXPECT_GE(h.reconnects, 1u);
    EXPECT_EQ(h.state, LinkState::Streaming);
    EXPECT_LT(r.worst_error_deg(3'500'000'000), 0.1);
}

TEST(I2cBno055, AMissingAdapterIsAClearErrorNotACrash) {
    recording::VirtualClock clock(0);
    LinuxBno055Source src("i2c:/dev/i2c-97", "/dev/i2c-97", 0x28, clock);
    src.run_until(2'000'000);  // past the chip's boot grace (650 ms), where silence is expected
    const LinkHealth h = src.health();
    EXPECT_EQ(h.samples, 0u);
    EXPECT_EQ(h.state, LinkState::Disconnected);
    EXPECT_NE(h.last_error.find("/dev/i2c-97"), std::string::npos) << h.last_error;
    EXPECT_NE(h.last_error.find("No such file"), std::string::npos) << h.last_error;
}

TEST(I2cBno055, RejectsAnAddressThatIsNotABno055s) {
    recording::VirtualClock clock(0);
    EXPECT_THROW(LinuxBno055Source("i2c:x", "/dev/i2c-1", 0x30, clock), SourceError);
}

}  // namespace
}  // namespace glint::host
