// glTF metallic-roughness mapped to Phong (material.hpp, material_from_gltf), the glTF reader's
// materials (gltf.cpp), and the mapping's error against glTF's own GGX model, whose table is in
// docs/render.md ("Materials from glTF").
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <vector>

#include "appliance/core/errors.hpp"
#include "appliance/render/material.hpp"
#include "appliance/render/mesh.hpp"
#include "test_support.hpp"

namespace glint::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(PbrToPhong, MapsTheFactors) {
    GltfMaterial plastic{"plastic", {0.8, 0.2, 0.1}, 0.0, 0.5, false};
    const Material p = material_from_gltf(plastic);
    EXPECT_EQ(p.kd, glm::dvec3(0.8, 0.2, 0.1));
    EXPECT_EQ(p.ks, glm::dvec3(0.04));
    EXPECT_DOUBLE_EQ(p.n, 7.5);  // alpha 0.25: 1 / (2 * 0.0625) - 0.5
    EXPECT_FALSE(p.mirror);
    EXPECT_NE(p.spec.find("plastic"), std::string::npos);

    GltfMaterial gold{"gold", {1.0, 0.77, 0.34}, 1.0, 0.3, false};
    const Material g = material_from_gltf(gold);
    EXPECT_EQ(g.kd, glm::dvec3(0.0));
    EXPECT_NEAR(g.ks.y, 0.77, 1e-12);
    EXPECT_DOUBLE_EQ(g.n, 61.23);  // 1 / (2 * 0.0081) - 0.5 = 61.228..., four digits

    GltfMaterial half{"half", {0.5, 0.5, 0.5}, 0.5, 1.0, false};
    const Material h = material_from_gltf(half);
    EXPECT_NEAR(h.kd.x, 0.25, 1e-12);
    EXPECT_NEAR(h.ks.x, 0.27, 1e-12);  // lerp(0.04, 0.5, 0.5)
    EXPECT_EQ(h.n, 0.0);               // roughness 1: the flattest lobe

    GltfMaterial chrome{"chrome", {0.9, 0.9, 0.9}, 1.0, 0.0, false};
    EXPECT_TRUE(material_from_gltf(chrome).mirror);
    EXPECT_TRUE(std::isinf(phong_exponent_from_roughness(0.04)));
    EXPECT_FALSE(std::isinf(phong_exponent_from_roughness(0.05)));
}

std::string base64(const std::vector<unsigned char>& bytes) {
    static const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    std::string out;
    for (std::size_t i = 0; i < bytes.size(); i += 3) {
        const unsigned v = unsigned(bytes[i]) << 16 | (i + 1 < bytes.size() ? unsigned(bytes[i + 1]) << 8 : 0u) |
                           (i + 2 < bytes.size() ? unsigned(bytes[i + 2]) : 0u);
        out += table[(v >> 18) & 63];
        out += table[(v >> 12) & 63];
        out += i + 1 < bytes.size() ? table[(v >> 6) & 63] : '=';
        out += i + 2 < bytes.size() ? table[v & 63] : '=';
    }
    return out;
}

class GltfMaterials : public testing::TempDirTest {};

// Two triangles in two primitives: the second uses material 1, the first material 0; material 2
// is defined but unused. The reader lists the used ones in order of first use.
TEST_F(GltfMaterials, ReadsTheFactorsOfTheMaterialsUsed) {
    const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    std::vector<unsigned char> bytes(sizeof pos);
    std::memcpy(bytes.data(), pos, sizeof pos);
    const std::string gltf = R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 1},
                                   {"attributes": {"POSITION": 0}, "material": 0},
                                   {"attributes": {"POSITION": 0}, "material": 1}]}],
        "materials": [{"name": "red plastic", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.1, 0.1, 1],
                                                                        "metallicFactor": 0, "roughnessFactor": 0.4}},
                      {"name": "steel", "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.62, 1],
                                                                 "baseColorTexture": {"index": 0}}},
                      {"name": "unused"}],
        "buffers": [{"byteLength": 36, "uri": "data:application/octet-stream;base64,)" +
                             base64(bytes) + R"("}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]}]})";
    const auto path = dir_ / "two.gltf";
    std::ofstream(path) << gltf;
    const Mesh m = load_gltf(path);
    ASSERT_EQ(m.triangle_count(), 3u);
    ASSERT_EQ(m.materials.size(), 2u);
    EXPECT_EQ(m.materials[0].name, "steel");
    EXPECT_DOUBLE_EQ(m.materials[0].metallic, 1.0);  // glTF's defaults
    EXPECT_DOUBLE_EQ(m.materials[0].roughness, 1.0);
    EXPECT_TRUE(m.materials[0].textured);
    EXPECT_EQ(m.materials[1].name, "red plastic");
    EXPECT_NEAR(m.materials[1].base_color.x, 0.8, 1e-6);
    EXPECT_DOUBLE_EQ(m.materials[1].metallic, 0.0);
    EXPECT_NEAR(m.materials[1].roughness, 0.4, 1e-6);
    EXPECT_FALSE(m.materials[1].textured);
    // One part per primitive (materials alternate, so none merge), each with its material.
    ASSERT_EQ(m.parts.size(), 3u);
    EXPECT_EQ(m.parts[0].material, 0);
    EXPECT_EQ(m.parts[1].material, 1);
    EXPECT_EQ(m.parts[2].material, 0);
    EXPECT_EQ(m.parts[1].first_index, 3u);
    EXPECT_EQ(m.parts[2].index_count, 3u);
    const std::vector<Material> per_part = part_materials(m, parse_material("matte"), false);
    ASSERT_EQ(per_part.size(), 3u);
    EXPECT_EQ(per_part[0].spec, per_part[2].spec);
    EXPECT_NE(per_part[0].spec, per_part[1].spec);
    // steel: phong_0; red plastic: diffuse and its own lobe: three distinct maps in all.
    EXPECT_EQ(needed_maps(per_part).size(), 3u);

    std::string bad = gltf;
    bad.replace(bad.find("\"metallicFactor\": 0"), 19, "\"metallicFactor\": 2");
    std::ofstream(dir_ / "bad.gltf") << bad;
    try {
        load_gltf(dir_ / "bad.gltf");
        ADD_FAILURE() << "a metallic factor of 2 was accepted";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("bad.gltf"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("red plastic"), std::string::npos) << e.what();
    }
}

// glTF 2.0's specular BRDF (its Appendix B): GGX distribution, height-correlated Smith
// visibility, Schlick's Fresnel; times cos(theta_l): the lobe's density over light directions L.
double ggx_lobe(const glm::dvec3& n, const glm::dvec3& v, const glm::dvec3& l, double alpha, double f0) {
    const double nl = glm::dot(n, l), nv = glm::dot(n, v);
    if (nl <= 0 || nv <= 0) return 0;
    const glm::dvec3 h = glm::normalize(v + l);
    const double nh = glm::dot(n, h), a2 = alpha * alpha;
    const double d = nh * nh * (a2 - 1) + 1;
    const double distribution = a2 / (kPi * d * d);
    const double visibility =
        0.5 / (nl * std::sqrt(nv * nv * (1 - a2) + a2) + nv * std::sqrt(nl * nl * (1 - a2) + a2));
    const double fresnel = f0 + (1 - f0) * std::pow(1 - std::abs(glm::dot(v, h)), 5);
    return fresnel * distribution * visibility * nl;
}

struct LobeStats {
    double albedo = 0;   // integral of the lobe (F0 = 1): the reflectance
    double hwhm = 0;     // degrees from R where the lobe (averaged around R) falls to half its peak
    double disc5 = 0;    // fraction of the lobe within 5 degrees of R
    double disc20 = 0;   // and within 20 degrees
};

// The GGX lobe integrated on a polar grid about R (theta = pi s^2: fine near R, where a lobe of
// roughness 0.1 is 0.7 degrees wide).
LobeStats ggx_stats(double roughness, double incidence_deg) {
    const glm::dvec3 n(0, 0, 1);
    const double tv = incidence_deg * kPi / 180;
    const glm::dvec3 v(std::sin(tv), 0, std::cos(tv));
    const glm::dvec3 r = 2 * glm::dot(n, v) * n - v;
    const glm::dvec3 t = glm::normalize(glm::cross(glm::dvec3(0, 1, 0), r)), b = glm::cross(r, t);
    const int ns = 4000, np = incidence_deg == 0 ? 1 : 120;  // at normal incidence the lobe is symmetric about R
    const double alpha = roughness * roughness;
    LobeStats s;
    std::vector<double> profile(ns);
    for (int i = 0; i < ns; ++i) {
        const double u = (i + 0.5) / ns, th = kPi * u * u, dth = 2 * kPi * u / ns;
        double ring = 0;
        for (int j = 0; j < np; ++j) {
            const double ph = 2 * kPi * (j + 0.5) / np;
            const glm::dvec3 l = std::cos(th) * r + std::sin(th) * (std::cos(ph) * t + std::sin(ph) * b);
            ring += ggx_lobe(n, v, l, alpha, 1.0);
        }
        ring /= np;
        profile[std::size_t(i)] = ring;
        const double w = ring * std::sin(th) * dth * 2 * kPi;
        s.albedo += w;
        if (th < 5 * kPi / 180) s.disc5 += w;
        if (th < 20 * kPi / 180) s.disc20 += w;
    }
    s.disc5 /= s.albedo;
    s.disc20 /= s.albedo;
    for (int i = 0; i < ns; ++i)
        if (profile[std::size_t(i)] < profile[0] / 2) {
            const double u = (i + 0.5) / ns;
            s.hwhm = kPi * u * u * 180 / kPi;
            break;
        }
    return s;
}

// The conventions' normalised Phong lobe cos^n about R, in closed form: its fraction within
// beta is 1 - cos^(n+1)(beta), its half maximum at acos(2^(-1/n)).
LobeStats phong_stats(double n) {
    LobeStats s;
    s.albedo = 1;
    s.hwhm = n > 0 ? std::acos(std::pow(0.5, 1 / n)) * 180 / kPi : 90;
    s.disc5 = 1 - std::pow(std::cos(5 * kPi / 180), n + 1);
    s.disc20 = 1 - std::pow(std::cos(20 * kPi / 180), n + 1);
    return s;
}

// The mapping's error, printed as the table of docs/render.md. Asserted: for roughness 0.3 to 0.7
// at normal incidence the fraction of light a 5-degree disc light at R reflects is within 0.03 of
// GGX's and a 20-degree one within 0.2; over the whole table the mapping's total error is under
// half that of using Blinn-Phong's exponent 2/alpha^2 - 2 directly on the lobe about R.
TEST(PbrToPhong, LobeAgainstGgx) {
    double ours = 0, blinn = 0;
    std::printf("| incidence | roughness | n | HWHM GGX / Phong (deg) | 5-deg disc GGX / Phong (/ n=2/a^2-2) | 20-deg disc GGX / Phong (/ n=2/a^2-2) | GGX albedo (F0 = 1) |\n");
    for (double incidence : {0.0, 45.0})
        for (double roughness : {0.1, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0}) {
            const double alpha = roughness * roughness;
            const double n = phong_exponent_from_roughness(roughness);
            const LobeStats g = ggx_stats(roughness, incidence), p = phong_stats(n),
                            b = phong_stats(2 / (alpha * alpha) - 2);
            std::printf("| %2.0f | %.1f | %.4g | %.2f / %.2f | %.3f / %.3f (/ %.3f) | %.3f / %.3f (/ %.3f) | %.3f |\n",
                        incidence, roughness, n, g.hwhm, p.hwhm, g.disc5, p.disc5, b.disc5, g.disc20, p.disc20,
                        b.disc20, g.albedo);
            ours += std::abs(p.disc5 - g.disc5) + std::abs(p.disc20 - g.disc20);
            blinn += std::abs(b.disc5 - g.disc5) + std::abs(b.disc20 - g.disc20);
            if (roughness == 0.1) {
                EXPECT_GT(g.albedo, 0.99);  // the integration holds the whole lobe
            }
            if (incidence == 0 && roughness >= 0.3 && roughness <= 0.7) {
                EXPECT_NEAR(p.disc5, g.disc5, 0.03) << roughness;
                EXPECT_NEAR(p.disc20, g.disc20, 0.2) << roughness;
            }
        }
    std::printf("total |disc error|: ours %.3f, Blinn-Phong's exponent on R %.3f\n", ours, blinn);
    EXPECT_LT(ours, 0.5 * blinn);
}

}  // namespace
}  // namespace glint::render
