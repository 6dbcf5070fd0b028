// Which connector and mode a KMS display drives, decided from a plain description of the card's
// resources (no DRM calls), so the choice is unit-tested against made-up cards. display_kms.cpp
// fills KmsCard from libdrm and calls choose_kms_output.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace glint::gl {

struct KmsMode {
    int width = 0, height = 0;
    double refresh_hz = 0;  // vertical refresh, from the mode's clock and totals
    bool preferred = false; // DRM_MODE_TYPE_PREFERRED: the monitor's native mode
    int index = 0;          // position in the connector's mode list (libdrm's order)
};

struct KmsConnector {
    std::uint32_t id = 0;
    std::string name;       // "HDMI-A-1", "DSI-1": type name and type index, as the kernel names it
    bool connected = false;
    std::vector<KmsMode> modes;
    std::vector<std::uint32_t> possible_crtcs;  // CRTC ids any of its encoders can drive
    std::uint32_t current_crtc = 0;             // driving it now (0: none)
};

struct KmsCard {
    std::string path;  // "/dev/dri/card0", named in every error
    std::vector<KmsConnector> connectors;
};

// What the config asks for; empty = choose.
struct KmsRequest {
    std::string connector;  // e.g. "HDMI-A-1"
    std::string mode;       // "WIDTHxHEIGHT" or "WIDTHxHEIGHT@HZ" (refresh within 0.5 Hz)
};

struct KmsChoice {
    std::size_t connector = 0;  // index into card.connectors
    std::size_t mode = 0;       // index into that connector's modes
    std::uint32_t crtc = 0;
};

// The connector: the requested one (which must be connected), else the first connected one.
// The mode: the requested one, else the preferred one, else the largest (then the fastest).
// The CRTC: the one driving the connector now, else the first it can use. Throws RuntimeError
// with one line naming the card: "no connected connector", "no connector named X", "X is not
// connected", "no such mode WxH on X (it has ...)", "no CRTC for X".
KmsChoice choose_kms_output(const KmsCard& card, const KmsRequest& request);

// "1920x1080@60.00"
std::string describe_mode(const KmsMode& mode);

}  // namespace glint::gl
