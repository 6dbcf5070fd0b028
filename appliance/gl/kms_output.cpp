#include "appliance/gl/kms_output.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <cstdio>

#include "appliance/core/errors.hpp"

namespace glint::gl {

namespace {

struct ModeSpec {
    int width = 0, height = 0;
    double refresh_hz = 0;  // 0: any
};

// "1920x1080" or "1920x1080@60" (also "@59.94").
bool parse_mode(const std::string& text, ModeSpec& out) {
    int w = 0, h = 0, used = 0;
    if (std::sscanf(text.c_str(), "%dx%d%n", &w, &h, &used) != 2 || w <= 0 || h <= 0) return false;
    out = {w, h, 0};
    if (std::size_t(used) == text.size()) return true;
    if (text[std::size_t(used)] != '@') return false;
    double hz = 0;
    int used2 = 0;
    if (std::sscanf(text.c_str() + used + 1, "%lf%n", &hz, &used2) != 1 || !(hz > 0)) return false;
    if (std::size_t(used + 1 + used2) != text.size()) return false;
    out.refresh_hz = hz;
    return true;
}

std::string list_modes(const KmsConnector& c) {
    std::string s;
    for (std::size_t i = 0; i < c.modes.size() && i < 8; ++i) s += (i ? ", " : "") + describe_mode(c.modes[i]);
    if (c.modes.size() > 8) s += ", ...";
    return s.empty() ? "no modes" : s;
}

}  // namespace

std::string describe_mode(const KmsMode& mode) {
    char text[64];
    std::snprintf(text, sizeof text, "%dx%d@%.2f", mode.width, mode.height, mode.refresh_hz);
    return text;
}

KmsChoice choose_kms_output(const KmsCard& card, const KmsRequest& request) {
    KmsChoice choice;
    const std::string& at = card.path;
    // The connector.
    bool found = false;
    if (!request.connector.empty()) {
        for (std::size_t i = 0; i < card.connectors.size(); ++i)
            if (card.connectors[i].name == request.connector) {
                if (!card.connectors[i].connected)
                    throw RuntimeError(at + ": connector " + request.connector + " is not connected");
                choice.connector = i;
                found = true;
            }
        if (!found) {
            std::string names;
            for (const KmsConnector& c : card.connectors) names += (names.empty() ? "" : ", ") + c.name;
            throw RuntimeError(at + ": no connector named " + request.connector + " (the card has " +
                               (names.empty() ? "none" : names) + ")");
        }
    } else {
        for (std::size_t i = 0; i < card.connectors.size() && !found; ++i)
            if (card.connectors[i].connected && !card.connectors[i].modes.empty()) {
                choice.connector = i;
                found = true;
            }
        if (!found) throw RuntimeError(at + ": no connected connector (is a display plugged in and on?)");
    }
    const KmsConnector& c = card.connectors[choice.connector];
    if (c.modes.empty()) throw RuntimeError(at + ": connector " + c.name + " reports no modes");

    // The mode.
    if (!request.mode.empty()) {
        ModeSpec want;
        if (!parse_mode(request.mode, want))
            throw RuntimeError(at + ": mode \"" + request.mode + "\" is not WIDTHxHEIGHT or WIDTHxHEIGHT@HZ");
        found = false;
        // Among the matching modes: with a refresh asked for, the nearest to it; else the
        // preferred one, else the fastest (a monitor lists 1080p at 60, 59.94, 50 ..., and
        // "1920x1080" means its usual one).
        const auto better = [&](const KmsMode& m, const KmsMode& b) {
            if (want.refresh_hz > 0) return std::abs(m.refresh_hz - want.refresh_hz) < std::abs(b.refresh_hz - want.refresh_hz);
            if (m.preferred != b.preferred) return m.preferred;
            return m.refresh_hz > b.refresh_hz;
        };
        for (std::size_t i = 0; i < c.modes.size(); ++i) {
            const KmsMode& m = c.modes[i];
            if (m.width != want.width || m.height != want.height) continue;
            if (want.refresh_hz > 0 && std::abs(m.refresh_hz - want.refresh_hz) > 0.5) continue;
            if (!found || better(m, c.modes[choice.mode])) {
                choice.mode = i;
                found = true;
            }
        }
        if (!found)
            throw RuntimeError(at + ": no such mode " + request.mode + " on " + c.name + " (it has " + list_modes(c) + ")");
    } else {
        found = false;
        for (std::size_t i = 0; i < c.modes.size() && !found; ++i)
            if (c.modes[i].preferred) {
                choice.mode = i;
                found = true;
            }
        if (!found)
            for (std::size_t i = 1; i < c.modes.size(); ++i) {
                const KmsMode& m = c.modes[i];
                const KmsMode& b = c.modes[choice.mode];
                const long long area = (long long)m.width * m.height, best_area = (long long)b.width * b.height;
                if (area > best_area || (area == best_area && m.refresh_hz > b.refresh_hz)) choice.mode = i;
            }
    }

    // The CRTC.
    if (c.current_crtc) {
        choice.crtc = c.current_crtc;
    } else if (!c.possible_crtcs.empty()) {
        choice.crtc = c.possible_crtcs.front();
    } else {
        throw RuntimeError(at + ": no CRTC can drive connector " + c.name);
    }
    return choice;
}

std::string fourcc_name(std::uint32_t format) {
    std::string s;
    for (int i = 0; i < 4; ++i) {
        const char c = char((format >> (8 * i)) & 0xff);
        s += (c >= 32 && c < 127) ? c : '?';
    }
    return s;
}

std::size_t choose_primary_plane(const std::string& card, const std::vector<KmsPlane>& planes, int crtc_index,
                                 std::uint32_t crtc_id, std::uint32_t format) {
    if (planes.empty()) throw RuntimeError(card + ": no planes (the driver lists none with universal planes on)");
    if (crtc_index < 0 || crtc_index >= 32)
        throw RuntimeError(card + ": CRTC " + std::to_string(crtc_id) + " is not among the first 32 a plane can name");
    bool primary_for_crtc = false;
    std::optional<std::size_t> found;
    for (std::size_t i = 0; i < planes.size(); ++i) {
        const KmsPlane& p = planes[i];
        const auto type = p.properties.find("type");
        if (type == p.properties.end() || type->second.value != std::uint64_t(kPlaneTypePrimary)) continue;
        if (!(p.possible_crtcs & (1u << crtc_index))) continue;
        primary_for_crtc = true;
        if (std::find(p.formats.begin(), p.formats.end(), format) == p.formats.end()) continue;
        const auto on = p.properties.find("CRTC_ID");
        if (on != p.properties.end() && on->second.value == crtc_id) return i;  // on this CRTC now
        if (!found) found = i;
    }
    if (found) return *found;
    throw RuntimeError(card + ": no primary plane for CRTC " + std::to_string(crtc_id) +
                       (primary_for_crtc ? " that scans out " + fourcc_name(format) : ""));
}

std::vector<AtomicSet> atomic_modeset(const AtomicOutput& out, std::uint32_t mode_blob, std::uint32_t fb) {
    const std::uint64_t w = std::uint64_t(out.width), h = std::uint64_t(out.height);
    std::vector<AtomicSet> sets{
        {out.connector, "connector", "CRTC_ID", out.crtc},
        {out.crtc, "CRTC", "MODE_ID", mode_blob},
        {out.crtc, "CRTC", "ACTIVE", 1},
        {out.plane, "plane", "FB_ID", fb},
        {out.plane, "plane", "CRTC_ID", out.crtc},
        {out.plane, "plane", "SRC_X", 0},
        {out.plane, "plane", "SRC_Y", 0},
        {out.plane, "plane", "SRC_W", w << 16},
        {out.plane, "plane", "SRC_H", h << 16},
        {out.plane, "plane", "CRTC_X", 0},
        {out.plane, "plane", "CRTC_Y", 0},
        {out.plane, "plane", "CRTC_W", w},
        {out.plane, "plane", "CRTC_H", h},
    };
    for (const std::uint32_t p : out.planes_off) {
        sets.push_back({p, "plane", "FB_ID", 0});
        sets.push_back({p, "plane", "CRTC_ID", 0});
    }
    return sets;
}

std::vector<AtomicSet> atomic_flip(const AtomicOutput& out, std::uint32_t fb) {
    return {{out.plane, "plane", "FB_ID", fb}};
}

std::vector<AtomicIds> resolve_atomic(const std::string& card, const std::vector<AtomicSet>& sets,
                                      const std::map<std::uint32_t, KmsProperties>& properties) {
    std::vector<AtomicIds> ids;
    ids.reserve(sets.size());
    for (const AtomicSet& s : sets) {
        const std::string object = std::string(s.object_kind) + " " + std::to_string(s.object);
        const auto props = properties.find(s.object);
        if (props == properties.end()) throw RuntimeError(card + ": " + object + " has no properties");
        const auto p = props->second.find(s.property);
        if (p == props->second.end()) throw RuntimeError(card + ": " + object + " has no property " + s.property);
        ids.push_back({s.object, p->second.id, s.value});
    }
    return ids;
}

}  // namespace glint::gl
