// The Modbus pan/tilt head driver against a libmodbus server with the same register map: over
// TCP on 127.0.0.1 and RTU over a pseudo-terminal; a server that stops answering; garbage
// register values. Real sockets and ptys, so waits are bounded by generous limits.
#include <gtest/gtest.h>

#include <mutex>

#include "appliance/core/rotation.hpp"
#include "firmware_bridge/host/modbus_head_sim.hpp"
#include "firmware_bridge/host/modbus_head_source.hpp"
#include "host_test_support.hpp"

namespace glint::host {
namespace {

using test::Collector;
using test::eventually;
constexpr double kDeg = 3.14159265358979323846 / 180.0;

TEST(ModbusHead, OrientationFollowsTheDocumentedFrame) {
    // Azimuth 90: looking east (+X); elevation 30: looking up.
    const glm::dvec3 east = head_orientation(90 * kDeg, 0) * glm::dvec3(0, 0, -1);
    EXPECT_NEAR(east.x, 1.0, 1e-12);
    const glm::dvec3 up = head_orientation(0, 30 * kDeg) * glm::dvec3(0, 0, -1);
    EXPECT_NEAR(up.y, 0.5, 1e-12);
    EXPECT_NEAR(up.z, -std::cos(30 * kDeg), 1e-12);
}

TEST(ModbusHead, ReadsTheAnglesOverTcp) {
    auto head = ModbusHeadSimulator::tcp();
    head->set_angles(123.45, -20.5);
    recording::SteadyClock clock;
    auto src = ModbusHeadSource::tcp("modbus-tcp:127.0.0.1:" + std::to_string(head->port()), "127.0.0.1", head->port(),
                                     clock);
    Collector c;
    c.attach(*src);
    src->start();
    ASSERT_TRUE(eventually([&] { return c.count() >= 10; })) << src->health().last_error;
    EXPECT_NEAR(angle_between(c.last().world_from_sensor, head_orientation(123.45 * kDeg, -20.5 * kDeg)), 0.0,
                0.01 * kDeg);
    head->set_angles(-170, 45);
    ASSERT_TRUE(eventually([&] {
        return angle_between(c.last().world_from_sensor, head_orientation(-170 * kDeg, 45 * kDeg)) < 0.01 * kDeg;
    }));
    const LinkHealth h = src->health();
    EXPECT_EQ(h.state, LinkState::Streaming);
    EXPECT_EQ(h.timeouts + h.frame_errors, 0u);
}

TEST(ModbusHead, ReadsTheAnglesOverRtuOnAPty) {
    auto head = ModbusHeadSimulator::rtu();
    head->set_angles(10, 5);
    recording::SteadyClock clock;
    auto src = ModbusHeadSource::rtu("modbus-rtu:" + head->device(), head->device(), 19200, clock);
    Collector c;
    c.attach(*src);
    src->start();
    ASSERT_TRUE(eventually([&] { return c.count() >= 5; })) << src->health().last_error;
    EXPECT_NEAR(angle_between(c.last().world_from_sensor, head_orientation(10 * kDeg, 5 * kDeg)), 0.0, 0.01 * kDeg);
}

TEST(ModbusHead, AServerThatStopsAnsweringIsReportedAndRecovered) {
    auto head = ModbusHeadSimulator::tcp();
    head->set_angles(30, 0);
    recording::SteadyClock clock;
    SourceOptions so;
    so.stall_after_ns = 200'000'000;
    ModbusHeadOptions ho;
    ho.response_timeout = std::chrono::milliseconds(50);
    auto src = ModbusHeadSource::tcp("modbus-tcp:head", "127.0.0.1", head->port(), clock, so, ho);
    Collector c;
    c.attach(*src);
    src->start();
    ASSERT_TRUE(eventually([&] { return c.count() >= 5; }));
    head->set_answering(false);
    ASSERT_TRUE(eventually([&] { return src->health().state != LinkState::Streaming; }));
    ASSERT_TRUE(eventually([&] { return src->health().timeouts >= 3; }));
    EXPECT_NE(src->health().last_error.find("no answer"), std::string::npos) << src->health().last_error;
    const std::size_t before = c.count();
    head->set_answering(true);
    ASSERT_TRUE(eventually([&] { return c.count() >= before + 5; })) << src->health().last_error;
    EXPECT_EQ(src->health().state, LinkState::Streaming);
}

TEST(ModbusHead, RegisterValuesThatCannotBeAnOrientationAreNeverPublished) {
    auto head = ModbusHeadSimulator::tcp();
    head->set_angles(0, 0);
    recording::SteadyClock clock;
    auto src = ModbusHeadSource::tcp("modbus-tcp:head", "127.0.0.1", head->port(), clock);
    Collector c;
    c.attach(*src);
    src->start();
    ASSERT_TRUE(eventually([&] { return c.count() >= 3; }));
    // An elevation past the zenith: 100 degrees of 36000 counts per revolution.
    head->set_raw_register(modbus_map::kElevationHi, 0);
    head->set_raw_register(modbus_map::kElevationHi + 1, 10000);
    ASSERT_TRUE(eventually([&] { return src->health().frame_errors >= 3; }));
    EXPECT_NE(src->health().last_error.find("elevation"), std::string::npos) << src->health().last_error;
    const std::size_t frozen_at = c.count();
    head->set_status(modbus_map::kStatusReady | modbus_map::kStatusFault);
    head->set_angles(0, 0);
    ASSERT_TRUE(eventually([&] { return src->health().last_error.find("fault") != std::string::npos; }));
    EXPECT_LE(c.count(), frozen_at + 1);  // nothing published while the data is unusable
    head->set_status(modbus_map::kStatusReady);
    head->freeze_heartbeat(true);
    ASSERT_TRUE(eventually([&] { return src->health().last_error.find("heartbeat") != std::string::npos; }));
    head->freeze_heartbeat(false);
    const std::size_t before = c.count();
    ASSERT_TRUE(eventually([&] { return c.count() >= before + 3; }));
    EXPECT_NEAR(angle_between(c.last().world_from_sensor, head_orientation(0, 0)), 0.0, 1e-9);
}

TEST(ModbusHead, NobodyListeningIsAClearError) {
    recording::SteadyClock clock;
    auto src = ModbusHeadSource::tcp("modbus-tcp:127.0.0.1:1", "127.0.0.1", 1, clock);
    src->start();
    ASSERT_TRUE(eventually([&] { return !src->health().last_error.empty(); }));
    EXPECT_EQ(src->health().state, LinkState::Disconnected);
    EXPECT_NE(src->health().last_error.find("127.0.0.1:1"), std::string::npos) << src->health().last_error;
}

}  // namespace
}  // namespace glint::host
