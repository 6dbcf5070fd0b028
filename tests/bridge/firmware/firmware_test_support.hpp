// Helpers shared by the firmware tests: angle conversions and decoding a byte stream.
#pragma once

#include <cmath>
#include <cstdint>
#include <numbers>
#include <span>
#include <vector>

#include "firmware_bridge/firmware/rotation.hpp"
#include "firmware_bridge/protocol/frame_decoder.hpp"

namespace glint::firmware::test {

inline constexpr double kDeg = std::numbers::pi / 180.0;

inline double angle_deg(Quatd a, Quatd b) { return angle_between(normalized(a), normalized(b)) / kDeg; }

// Every frame event in `bytes`, in order.
inline std::vector<protocol::FrameEvent> decode_all(protocol::FrameDecoder& decoder,
                                                   std::span<const std::uint8_t> bytes) {
    std::vector<protocol::FrameEvent> events;
    decoder.feed_all(bytes, [&](const protocol::FrameEvent& e) { events.push_back(e); });
    return events;
}

inline Quatd quat_from_orientation(const protocol::Orientation& o) {
    return {protocol::from_q30(o.w_q30), protocol::from_q30(o.x_q30), protocol::from_q30(o.y_q30),
            protocol::from_q30(o.z_q30)};
}

}  // namespace glint::firmware::test
