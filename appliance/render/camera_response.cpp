#include "appliance/render/camera_response.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "appliance/core/errors.hpp"

namespace glint::render {

double CameraResponse::code(double x) const {
    if (parametric()) {
        // As capture's Response::forward (camera_model.cpp): the simulator's camera exactly.
        if (!(x > 0)) return 0;
        const double root = std::pow(x, 1 / gamma);
        return std::min(255.0, 255.0 * (1 + shoulder) * root / (root + shoulder));
    }
    if (!(x > inverse[0])) return 0;
    if (x >= inverse[255]) return 255;
    const auto hi = std::upper_bound(inverse.begin(), inverse.end(), x);  // first > x
    const std::size_t z = std::size_t(hi - inverse.begin()) - 1;
    return double(z) + (x - inverse[z]) / (inverse[z + 1] - inverse[z]);
}

CameraResponse load_camera_response(const std::filesystem::path& path, const std::string& flag) {
    const std::string where = flag + " " + path.string();
    std::ifstream in(path);
    if (!in) throw InputError(where + ": cannot open the calibration");
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(in);
    } catch (const std::exception& e) {
        throw InputError(where + ": not JSON: " + e.what());
    }
    const auto number = [&](const nlohmann::json& o, const char* key, const std::string& name) {
        if (!o.is_object() || !o.contains(key) || !o[key].is_number() || !std::isfinite(o[key].get<double>()))
            throw InputError(where + ": \"" + name + "\" is missing or not a finite number");
        return o[key].get<double>();
    };
    if (!j.is_object() || !j.contains("response") || !j["response"].is_object())
        throw InputError(where + ": no \"response\" (a camera calibration from glint calibrate or glint simulate)");
    const nlohmann::json& r = j["response"];
    if (!r.contains("inverse") || !r["inverse"].is_array() || r["inverse"].size() != 256)
        throw InputError(where + ": \"response.inverse\" must hold 256 numbers");
    CameraResponse out;
    out.source = path.string();
    for (std::size_t z = 0; z < 256; ++z) {
        const nlohmann::json& v = r["inverse"][z];
        const double x = v.is_number() ? v.get<double>() : -1.0;
        if (!std::isfinite(x) || x < 0 || (z > 0 && !(x > out.inverse[z - 1])))
            throw InputError(where + ": \"response.inverse[" + std::to_string(z) + "]\" must be finite, >= 0 and increasing");
        out.inverse[z] = x;
    }
    out.gamma = number(r, "gamma", "response.gamma");
    out.shoulder = number(r, "shoulder", "response.shoulder");
    out.sensitivity = number(j, "sensitivity", "sensitivity");
    if (!(out.sensitivity > 0)) throw InputError(where + ": \"sensitivity\" must be positive");
    if (j.contains("noise")) {
        out.full_well_electrons = number(j["noise"], "full_well_electrons", "noise.full_well_electrons");
        out.read_noise = number(j["noise"], "read_noise", "noise.read_noise");
        if (!(out.full_well_electrons >= 1 && out.full_well_electrons <= 1e9))
            throw InputError(where + ": \"noise.full_well_electrons\" must be 1 to 1e9");
        if (!(out.read_noise >= 0 && out.read_noise < 1))
            throw InputError(where + ": \"noise.read_noise\" must be 0 to 1 (relative exposure)");
    }
    return out;
}

}  // namespace glint::render
