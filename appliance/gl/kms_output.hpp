// Which connector and mode a KMS display drives, decided from a plain description of the card's
// resources (no DRM calls), so the choice is unit-tested against made-up cards. display_kms.cpp
// fills KmsCard from libdrm and calls choose_kms_output.
#pragma once

#include <cstdint>
#include <map>
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

// --- Atomic modesetting (docs/architecture.md, "Displays") ----------------------------------
// The same split: display_kms.cpp reads the card's planes and properties into these, the choices
// and the property lists of each commit are made here and unit-tested against made-up cards.

// A KMS object's properties by name: property id and current value.
struct KmsProperty {
    std::uint32_t id = 0;
    std::uint64_t value = 0;
};
using KmsProperties = std::map<std::string, KmsProperty>;

inline constexpr int kPlaneTypeOverlay = 0, kPlaneTypePrimary = 1, kPlaneTypeCursor = 2;  // DRM_PLANE_TYPE_*

struct KmsPlane {
    std::uint32_t id = 0;
    std::uint32_t possible_crtcs = 0;  // bit i: the CRTC at index i of the card's CRTC list
    std::vector<std::uint32_t> formats;  // DRM fourcc codes it scans out
    KmsProperties properties;            // "type" among them on a card with universal planes
};

// The primary plane for the CRTC at `crtc_index` that scans out `format`, preferring one on that
// CRTC now (its "CRTC_ID" property; a primary may serve several CRTCs); throws RuntimeError with
// one line naming the card and the CRTC when there is none ("no primary plane for CRTC 41 that
// scans out XR24", or that the card lists no planes at all).
std::size_t choose_primary_plane(const std::string& card, const std::vector<KmsPlane>& planes, int crtc_index,
                                 std::uint32_t crtc_id, std::uint32_t format);

// One property set in an atomic commit, by name; resolve_atomic turns names into ids.
struct AtomicSet {
    std::uint32_t object = 0;
    const char* object_kind = "";  // "connector", "CRTC", "plane": for the error
    std::string property;
    std::uint64_t value = 0;
};
struct AtomicIds {
    std::uint32_t object = 0, property = 0;
    std::uint64_t value = 0;
};

struct AtomicOutput {
    std::uint32_t connector = 0, crtc = 0, plane = 0;
    int width = 0, height = 0;  // the mode's, which the plane fills 1:1
    std::vector<std::uint32_t> planes_off;  // other planes on the CRTC now, switched off by the mode set
};

// The first commit (needs DRM_MODE_ATOMIC_ALLOW_MODESET): the connector on the CRTC, the CRTC on
// with the mode's blob, the plane showing framebuffer `fb` whole (SRC_* in 16.16 fixed point), and
// the planes in planes_off off (FB_ID and CRTC_ID 0).
std::vector<AtomicSet> atomic_modeset(const AtomicOutput& out, std::uint32_t mode_blob, std::uint32_t fb);
// A page flip: only the plane's framebuffer changes.
std::vector<AtomicSet> atomic_flip(const AtomicOutput& out, std::uint32_t fb);

// Property names to ids from each object's properties (`properties`: object id -> its
// properties); throws RuntimeError naming the card, the object and the property one lacks
// ("/dev/dri/card0: plane 31 has no property FB_ID").
std::vector<AtomicIds> resolve_atomic(const std::string& card, const std::vector<AtomicSet>& sets,
                                      const std::map<std::uint32_t, KmsProperties>& properties);

// "XR24" for DRM_FORMAT_XRGB8888.
std::string fourcc_name(std::uint32_t format);

}  // namespace glint::gl
