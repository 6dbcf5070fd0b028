#include "appliance/capture/calibration_io.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/state_store.hpp"

namespace glint::capture {

namespace {

using nlohmann::json;

[[noreturn]] void bad(const std::string& source, const std::string& key, const std::string& why) {
    throw InputError(source + ": key '" + key + "': " + why);
}

const json& member(const json& j, const char* key, const std::string& source, const std::string& path) {
    const std::string full = path.empty() ? key : path + "." + key;
    if (!j.is_object() || !j.contains(key)) bad(source, full, "missing");
    return j.at(key);
}

double number(const json& j, const char* key, const std::string& source, const std::string& path) {
    const json& v = member(j, key, source, path);
    const std::string full = path.empty() ? key : path + "." + key;
    if (!v.is_number()) bad(source, full, "not a number");
    const double d = v.get<double>();
    if (!std::isfinite(d)) bad(source, full, "not finite");
    return d;
}

}  // namespace

// Values the camera model cannot use inside the image, which would pass every range check and
// make nonsense of the map (a sweep of bad inputs, 2026-12-06: vignetting a1 = -5 gave a map
// 18x off, k1 = 50 half the coverage): a vignetting falloff that reaches 0 or grows 20-fold
// (every radiance is divided by it), and a radial distortion r (1 + k1 r^2 + k2 r^4 + k3 r^6)
// that turns back before the image's farthest corner (two directions then share a pixel). Not
// the round trip through `undistort`: its fixed point stops short on wide but real lenses (k1 =
// -0.4, k2 = 0.2 at a 90-degree field), whose radial curve rises all the way.
void check_calibration_usable(const CameraCalibration& c, const std::string& source) {
    const Intrinsics& k = c.intrinsics;
    const double right = k.width - 1, bottom = k.height - 1;
    double corner = 0;  // the farthest pixel's distorted radius, normalised
    for (const double u : {0.0, 0.5 * right, right})
        for (const double v : {0.0, 0.5 * bottom, bottom}) {
            const double falloff = c.vignetting.at(k, u, v);
            if (!(falloff >= 0.05 && falloff <= 20))
                bad(source, "vignetting", "the falloff is " + std::to_string(falloff) + " at pixel (" +
                                              std::to_string(int(u)) + ", " + std::to_string(int(v)) +
                                              "); it must stay within 0.05 to 20 over the image");
            corner = std::max(corner, std::hypot((u - k.cx) / k.fx, (v - k.cy) / k.fy));
        }
    constexpr double kStep = 1e-3, kLongest = 50;
    double r = 0;
    for (double reached = 0; reached < corner; r += kStep) {
        const double r2 = r * r;
        const double slope = 1 + r2 * (3 * k.k1 + r2 * (5 * k.k2 + r2 * 7 * k.k3));
        if (!(slope > 0) || r > kLongest)
            bad(source, "intrinsics.k1/k2/k3",
                "the radial distortion turns back at radius " + std::to_string(r) + " before the image's corner (" +
                    std::to_string(corner) + "): two directions would share a pixel");
        reached = r * (1 + r2 * (k.k1 + r2 * (k.k2 + r2 * k.k3)));
    }
}

std::string calibration_to_json(const CameraCalibration& c) {
    const Intrinsics& k = c.intrinsics;
    json j;
    j["format"] = "glint-camera-calibration";
    j["version"] = kCalibrationVersion;
    j["intrinsics"] = {{"width", k.width}, {"height", k.height}, {"fx", k.fx}, {"fy", k.fy},
                       {"cx", k.cx},       {"cy", k.cy},         {"k1", k.k1}, {"k2", k.k2},
                       {"p1", k.p1},       {"p2", k.p2},         {"k3", k.k3}};
    j["vignetting"] = {{"a1", c.vignetting.a1}, {"a2", c.vignetting.a2}, {"a3", c.vignetting.a3}};
    j["response"] = {{"inverse", std::vector<double>(c.response.inverse.begin(), c.response.inverse.end())},
                     {"gamma", c.response.gamma},
                     {"shoulder", c.response.shoulder}};
    const glm::dquat& q = c.sensor_from_camera;
    j["sensor_from_camera"] = {q.w, q.x, q.y, q.z};
    j["time_offset_s"] = c.time_offset_s;
    j["sensitivity"] = c.sensitivity;
    j["shortest_exposure_s"] = c.min_exposure_s;
    j["glare"] = {{"fraction", c.glare_fraction}, {"sigma_rad", c.glare_sigma_rad}};
    j["readout_s"] = c.readout_s;
    if (c.noise_full_well_electrons > 0)
        j["noise"] = {{"full_well_electrons", c.noise_full_well_electrons}, {"read_noise", c.noise_read}};
    return j.dump(2) + "\n";
}

CameraCalibration calibration_from_json(const std::string& text, const std::string& source) {
    json j;
    try {
        j = json::parse(text);
    } catch (const json::exception& e) {  // parse_error, and out_of_range for a number beyond double's range
        throw InputError(source + ": not valid JSON (" + e.what() + ")");
    }
    const json& format = member(j, "format", source, "");
    if (!format.is_string() || format.get<std::string>() != "glint-camera-calibration")
        bad(source, "format", "not a Glint camera calibration");
    const double version = number(j, "version", source, "");
    if (version != kCalibrationVersion)
        // The file's own text of the number: int(version) is undefined beyond int's range.
        bad(source, "version", "version " + j.at("version").dump() + " is not supported (this build reads " +
                                   std::to_string(kCalibrationVersion) + ")");
    CameraCalibration c;
    const json& k = member(j, "intrinsics", source, "");
    Intrinsics& in = c.intrinsics;
    const double w = number(k, "width", source, "intrinsics"), h = number(k, "height", source, "intrinsics");
    if (w < 2 || h < 2 || w != std::floor(w) || h != std::floor(h) || w > 65535 || h > 65535)
        bad(source, "intrinsics.width/height", "must be whole numbers of pixels, at least 2");
    in.width = int(w);
    in.height = int(h);
    in.fx = number(k, "fx", source, "intrinsics");
    in.fy = number(k, "fy", source, "intrinsics");
    if (!(in.fx > 0) || !(in.fy > 0)) bad(source, "intrinsics.fx/fy", "must be positive");
    in.cx = number(k, "cx", source, "intrinsics");
    in.cy = number(k, "cy", source, "intrinsics");
    in.k1 = number(k, "k1", source, "intrinsics");
    in.k2 = number(k, "k2", source, "intrinsics");
    in.p1 = number(k, "p1", source, "intrinsics");
    in.p2 = number(k, "p2", source, "intrinsics");
    in.k3 = number(k, "k3", source, "intrinsics");
    const json& v = member(j, "vignetting", source, "");
    c.vignetting = {number(v, "a1", source, "vignetting"), number(v, "a2", source, "vignetting"),
                    number(v, "a3", source, "vignetting")};
    check_calibration_usable(c, source);
    const json& r = member(j, "response", source, "");
    const json& inv = member(r, "inverse", source, "response");
    if (!inv.is_array() || inv.size() != 256) bad(source, "response.inverse", "must hold 256 numbers");
    for (std::size_t z = 0; z < 256; ++z) {
        if (!inv[z].is_number()) bad(source, "response.inverse[" + std::to_string(z) + "]", "not a number");
        c.response.inverse[z] = inv[z].get<double>();
        if (!std::isfinite(c.response.inverse[z]) || c.response.inverse[z] < 0 ||
            (z > 0 && !(c.response.inverse[z] > c.response.inverse[z - 1])))
            bad(source, "response.inverse[" + std::to_string(z) + "]", "must be finite, >= 0 and increasing");
    }
    c.response.gamma = number(r, "gamma", source, "response");
    c.response.shoulder = number(r, "shoulder", source, "response");
    const json& q = member(j, "sensor_from_camera", source, "");
    if (!q.is_array() || q.size() != 4 || !q[0].is_number() || !q[1].is_number() || !q[2].is_number() ||
        !q[3].is_number())
        bad(source, "sensor_from_camera", "must be a quaternion [w, x, y, z]");
    const glm::dquat raw(q[0].get<double>(), q[1].get<double>(), q[2].get<double>(), q[3].get<double>());
    if (!(std::abs(glm::length(raw) - 1) < 1e-3)) bad(source, "sensor_from_camera", "not a unit quaternion");
    // A quaternion already unit to rounding is kept as read: renormalising it can move its last
    // digits, and a file this program wrote must read back to the same numbers.
    const bool unit_to_rounding = std::abs(glm::length(raw) - 1) <= 8 * std::numeric_limits<double>::epsilon();
    c.sensor_from_camera = unit_to_rounding ? (raw.w < 0 ? -raw : raw) : unit_rotation(raw);
    c.time_offset_s = number(j, "time_offset_s", source, "");
    c.sensitivity = number(j, "sensitivity", source, "");
    if (!(c.sensitivity > 0)) bad(source, "sensitivity", "must be positive");
    // The sensor's limits, optional (files before 2026-12-02 have none: no shortest exposure, no
    // glare).
    if (j.contains("shortest_exposure_s")) {
        c.min_exposure_s = number(j, "shortest_exposure_s", source, "");
        if (!(c.min_exposure_s >= 0 && c.min_exposure_s < 1)) bad(source, "shortest_exposure_s", "must be 0 to 1 s");
    }
    if (j.contains("glare")) {
        const json& g = member(j, "glare", source, "");
        c.glare_fraction = number(g, "fraction", source, "glare");
        c.glare_sigma_rad = number(g, "sigma_rad", source, "glare");
        if (!(c.glare_fraction >= 0 && c.glare_fraction < 1)) bad(source, "glare.fraction", "must be 0 to 1");
        if (!(c.glare_sigma_rad > 0 && c.glare_sigma_rad < 1)) bad(source, "glare.sigma_rad", "must be 0 to 1 rad");
    }
    // The rolling shutter's readout time, optional (files before 2026-12-02 have none: a global
    // shutter, which is what they were made with).
    if (j.contains("readout_s")) {
        c.readout_s = number(j, "readout_s", source, "");
        if (!(c.readout_s >= 0 && c.readout_s < 1)) bad(source, "readout_s", "must be 0 to 1 s");
    }
    // The sensor's noise, optional (what the renderer matches on virtual pixels).
    if (j.contains("noise")) {
        const json& n = member(j, "noise", source, "");
        c.noise_full_well_electrons = number(n, "full_well_electrons", source, "noise");
        c.noise_read = number(n, "read_noise", source, "noise");
        if (!(c.noise_full_well_electrons >= 1 && c.noise_full_well_electrons <= 1e9))
            bad(source, "noise.full_well_electrons", "must be 1 to 1e9");
        if (!(c.noise_read >= 0 && c.noise_read < 1)) bad(source, "noise.read_noise", "must be 0 to 1 (relative exposure)");
    }
    return c;
}

void save_calibration(const std::filesystem::path& path, const CameraCalibration& calibration) {
    if (state::is_store_item(path)) {
        state::save_item(path.parent_path(), path.filename().string(),
                         {state::text_file(path.filename().string(), calibration_to_json(calibration))});
        return;
    }
    write_text_atomically(path, calibration_to_json(calibration));
}

void save_state_calibration(const std::filesystem::path& state_dir, const CameraCalibration& calibration) {
    check_calibration_usable(calibration, (state_dir / kStateCalibrationName).string());
    state::save_item(state_dir, kStateCalibrationName, {state::text_file(kStateCalibrationName, calibration_to_json(calibration))});
}

namespace {

CameraCalibration read_calibration_file(const std::filesystem::path& path) {
    std::ifstream in(path);
    if (!in) throw InputError(path.string() + ": cannot open the camera calibration");
    std::stringstream text;
    text << in.rdbuf();
    return calibration_from_json(text.str(), path.string());
}

// A state item's calibration: verified, and a faulty one set aside (core/state_store.hpp).
std::optional<CameraCalibration> load_item_calibration(const std::filesystem::path& dir, const std::string& name,
                                                       const std::function<void(const std::string&)>& log,
                                                       state::LoadedItem& item) {
    std::optional<CameraCalibration> calibration;
    state::LoadPolicy policy;
    policy.files = {name};
    // A technician may copy a calibration in by hand (glint calibrate's, a session's): no checksum,
    // but it must parse.
    policy.unverified = state::Unverified::Accept;
    policy.check = [&](const std::filesystem::path& file) { calibration = read_calibration_file(file); };
    item = state::load_item(dir, name, policy, log);
    if (!item.path) return std::nullopt;
    return calibration;
}

}  // namespace

CameraCalibration load_calibration(const std::filesystem::path& path) {
    if (!state::is_store_item(path)) return read_calibration_file(path);
    // The state directory's calibration (a link into its generations): a bit flipped in a number
    // would still parse, so it is verified; a faulty one is set aside and named here.
    state::LoadedItem item;
    const std::optional<CameraCalibration> calibration =
        load_item_calibration(path.parent_path(), path.filename().string(), {}, item);
    if (!calibration)
        throw InputError(path.string() + ": the camera calibration did not verify: " + item.defaults_because +
                         (item.set_aside.empty() ? std::string() : "; set aside in " + item.set_aside.string()));
    return *calibration;
}

std::optional<CameraCalibration> load_state_calibration(const std::filesystem::path& state_dir,
                                                        const std::function<void(const std::string&)>& log) {
    state::LoadedItem item;
    return load_item_calibration(state_dir, kStateCalibrationName, log, item);
}

}  // namespace glint::capture
