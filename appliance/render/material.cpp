#include "appliance/render/material.hpp"

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "appliance/core/errors.hpp"
#include "appliance/core/strict_number.hpp"

namespace glint::render {
namespace {

// Shininess accepted: the range `glint convolve --shininess` takes.
constexpr double kMaxShininess = 1e7;

double parse_shininess(std::string_view text, const std::string& where) {
    const double n = parse_double(text, where);
    if (n < 0 || n > kMaxShininess)
        throw InputError(where + ": shininess " + std::string(text) + " is outside [0, 1e7]");
    return n;
}

glm::dvec3 parse_albedo(std::string_view text, const std::string& where) {
    std::vector<double> v;
    std::size_t k = 0;
    while (true) {
        const std::size_t comma = text.find(',', k);
        const std::string_view item = text.substr(k, comma == std::string_view::npos ? comma : comma - k);
        const double x = parse_double(item, where);
        if (x < 0) throw InputError(where + ": albedo " + std::string(item) + " is negative");
        v.push_back(x);
        if (comma == std::string_view::npos) break;
        k = comma + 1;
    }
    if (v.size() == 1) return glm::dvec3(v[0]);
    if (v.size() != 3) throw InputError(where + ": want R,G,B or one number, got '" + std::string(text) + "'");
    return {v[0], v[1], v[2]};
}

}  // namespace

std::string phong_label(double n) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "phong_%g", n);
    return buf;
}

Material parse_material(const std::string& text, const std::string& flag) {
    const std::string where = flag + " '" + text + "'";
    Material m;
    m.spec = text;
    if (text == "matte") {
        m.kd = glm::dvec3(1);
        m.ks = glm::dvec3(0);
        return m;
    }
    if (text == "mirror") {
        m.kd = glm::dvec3(0);
        m.ks = glm::dvec3(1);
        m.mirror = true;
        return m;
    }
    if (text.rfind("glossy:", 0) == 0) {
        m.kd = glm::dvec3(0);
        m.ks = glm::dvec3(1);
        m.n = parse_shininess(std::string_view(text).substr(7), where);
        return m;
    }
    if (text.find('=') == std::string::npos)
        throw InputError(where + ": not a material (want matte, glossy:N, mirror or kd=R,G,B;ks=R,G,B;n=N)");
    m.kd = glm::dvec3(0);
    m.ks = glm::dvec3(0);
    bool seen_kd = false, seen_ks = false, seen_n = false;
    std::size_t k = 0;
    while (k <= text.size()) {
        const std::size_t semi = text.find(';', k);
        const std::string item = text.substr(k, semi == std::string::npos ? std::string::npos : semi - k);
        k = semi == std::string::npos ? text.size() + 1 : semi + 1;
        if (item.empty()) continue;
        const std::size_t eq = item.find('=');
        if (eq == std::string::npos) throw InputError(where + ": '" + item + "' is not key=value");
        const std::string key = item.substr(0, eq);
        const std::string_view value = std::string_view(item).substr(eq + 1);
        bool* seen = key == "kd" ? &seen_kd : key == "ks" ? &seen_ks : key == "n" ? &seen_n : nullptr;
        if (!seen) throw InputError(where + ": unknown key '" + key + "' (kd, ks, n)");
        if (*seen) throw InputError(where + ": '" + key + "' given twice");
        *seen = true;
        if (key == "kd") m.kd = parse_albedo(value, where);
        else if (key == "ks") m.ks = parse_albedo(value, where);
        else m.n = parse_shininess(value, where);
    }
    if (!m.diffuse() && !m.specular()) throw InputError(where + ": kd and ks are both 0 (a black object)");
    return m;
}

double phong_exponent_from_roughness(double roughness) {
    const double alpha = roughness * roughness;
    const double n = alpha > 0 ? 0.5 / (alpha * alpha) - 0.5 : HUGE_VAL;
    return n > 1e5 ? HUGE_VAL : std::max(0.0, n);
}

Material material_from_gltf(const GltfMaterial& g) {
    Material m;
    m.kd = g.base_color * (1.0 - g.metallic);
    m.ks = glm::mix(glm::dvec3(0.04), g.base_color, g.metallic);
    const double n = phong_exponent_from_roughness(g.roughness);
    m.mirror = std::isinf(n);
    // Four significant digits: the exponent names the map (phong_label), and the lobe does not
    // change visibly below that.
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.4g", m.mirror ? 1.0 : n);
    m.n = std::strtod(buf, nullptr);
    char spec[256];
    std::snprintf(spec, sizeof spec, "gltf '%s' (base %.3g,%.3g,%.3g metallic %.3g roughness %.3g): kd=%.4g,%.4g,%.4g;ks=%.4g,%.4g,%.4g;%s",
                  g.name.c_str(), g.base_color.x, g.base_color.y, g.base_color.z, g.metallic, g.roughness, m.kd.x, m.kd.y,
                  m.kd.z, m.ks.x, m.ks.y, m.ks.z, m.mirror ? "mirror" : ("n=" + std::string(buf)).c_str());
    m.spec = spec;
    return m;
}

convolution::MapRequest reflection_request(const Material& material) {
    if (material.mirror) return convolution::MapRequest::make_mirror();
    char buf[64];
    std::snprintf(buf, sizeof buf, "%g", material.n);
    return convolution::MapRequest::make_phong(material.n, buf);
}

std::vector<convolution::MapRequest> needed_maps(const Material& material) {
    return needed_maps(std::vector<Material>{material});
}

std::vector<convolution::MapRequest> needed_maps(const std::vector<Material>& materials) {
    std::vector<convolution::MapRequest> maps;
    for (const Material& m : materials)
        if (m.diffuse()) {
            maps.push_back(convolution::MapRequest::make_irradiance());
            break;
        }
    for (const Material& m : materials) {
        if (!m.specular()) continue;
        convolution::MapRequest r = reflection_request(m);
        const bool seen = std::any_of(maps.begin(), maps.end(),
                                      [&](const convolution::MapRequest& q) { return q.label == r.label; });
        if (!seen) maps.push_back(std::move(r));
    }
    return maps;
}

Material material_from_mtl(const ObjMaterial& mtl) {
    Material m;
    m.kd = mtl.kd;
    m.ks = mtl.ks;
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.4g", mtl.ns / 4.0);
    m.n = std::strtod(buf, nullptr);
    char spec[256];
    std::snprintf(spec, sizeof spec, "mtl '%s' (Kd %.3g,%.3g,%.3g Ks %.3g,%.3g,%.3g Ns %.4g): kd=%.4g,%.4g,%.4g;ks=%.4g,%.4g,%.4g;n=%s",
                  mtl.name.c_str(), mtl.kd.x, mtl.kd.y, mtl.kd.z, mtl.ks.x, mtl.ks.y, mtl.ks.z, mtl.ns, m.kd.x, m.kd.y,
                  m.kd.z, m.ks.x, m.ks.y, m.ks.z, buf);
    m.spec = spec;
    return m;
}

std::vector<Material> part_materials(const Mesh& mesh, const Material& fallback, bool override_all) {
    if (mesh.parts.empty()) return {fallback};
    std::vector<Material> out;
    for (const MeshPart& part : mesh.parts) {
        if (override_all) {
            out.push_back(fallback);
        } else if (!mesh.materials.empty()) {
            out.push_back(material_from_gltf(mesh.materials.at(std::size_t(part.material))));
        } else {
            const ObjMaterial& o = mesh.obj_materials.at(std::size_t(part.material));
            out.push_back(o.defined ? material_from_mtl(o) : fallback);
        }
    }
    return out;
}

bool same_shading(const Material& a, const Material& b) {
    if (a.kd != b.kd || a.ks != b.ks) return false;
    if (!a.specular()) return true;
    return a.mirror == b.mirror && (a.mirror || a.n == b.n);
}

}  // namespace glint::render
