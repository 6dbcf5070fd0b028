#include "appliance/gl/kms_output.hpp"

#include <cmath>
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

}  // namespace glint::gl
