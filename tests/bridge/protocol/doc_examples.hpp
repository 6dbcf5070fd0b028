// The worked examples of PROTOCOL.md: the messages whose frames the document shows in hex.
// test_doc_examples.cpp encodes each and compares with the document, so the two never drift.
#pragma once

#include <cstdint>
#include <vector>

#include "firmware_bridge/protocol/messages.hpp"

namespace glint::protocol::test {

struct DocExample {
    const char* name;  // the `ex-...` tag of its row in PROTOCOL.md
    Message message;
    std::uint16_t seq;
};

inline std::vector<DocExample> doc_examples() {
    // 90 degrees about +Y (the sensor's -Z turned towards world -X): w = cos 45deg, y = sin 45deg.
    const std::int32_t c45 = to_q30(0.70710678118654752);
    return {
        {"ex-hello",
         Hello{1, 0, 1, 2, 3, 0x12345678u,
               capability::kGyro | capability::kAccel | capability::kMag | capability::kOnBoardFusion |
                   capability::kButtons,
               2},
         0},
        {"ex-orientation", Orientation{1'000'000, c45, 0, c45, 0}, 1},
        {"ex-raw-imu",
         RawImu{1'000'500, {0, 500'000, 0}, {0, 9'806'650, 0}, {20'000, -40'000, 0},
                raw_valid::kGyro | raw_valid::kAccel | raw_valid::kMag},
         2},
        {"ex-fusion-status", FusionStatus{2'000'000, FusionMode::Ndof, 3, 3, 3, 2, {-100, 50, 0}}, 3},
        {"ex-button-event", ButtonEvent{2'500'000, 0, ButtonState::Pressed}, 4},
        {"ex-heartbeat", Heartbeat{3'000'000, 3, 300, 0, 2, 0}, 5},
        {"ex-error-report",
         ErrorReport{3'100'000, static_cast<std::uint16_t>(ErrorCode::SensorNotResponding), capability::kMag}, 6},
        {"ex-hello-request", HelloRequest{}, 0},
        {"ex-config-get", ConfigGet{static_cast<std::uint16_t>(ConfigKey::OrientationRateHz)}, 1},
        {"ex-config-set",
         ConfigSet{static_cast<std::uint16_t>(ConfigKey::OrientationRateHz), ConfigValue::from_u32(100)}, 2},
        {"ex-config-ack",
         ConfigAck{2, static_cast<std::uint16_t>(ConfigKey::OrientationRateHz), ConfigStatus::Ok,
                   ConfigValue::from_u32(100)},
         7},
        {"ex-config-ack-read-only",
         ConfigAck{3, static_cast<std::uint16_t>(ConfigKey::BoardId), ConfigStatus::ReadOnly,
                   ConfigValue::from_u32(0x12345678u)},
         8},
    };
}

}  // namespace glint::protocol::test
