// Phong materials as the 2015 paper's seeds shade them (docs/conventions.md, "Shading"):
//   L_o = kd * E_d(N) * ao + ks * E_s^n(R)
// with E_d the irradiance map and E_s^n the normalised Phong reflection map of shininess n.
#pragma once

#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "appliance/convolution/convolution.hpp"
#include "appliance/render/mesh.hpp"

namespace glint::render {

struct Material {
    glm::dvec3 kd{1.0};   // diffuse albedo per channel, >= 0
    glm::dvec3 ks{0.0};   // specular albedo per channel, >= 0
    double n = 1.0;       // Phong shininess, >= 0 (ignored for a mirror)
    bool mirror = false;  // n = infinity: the mirror map (convolution's MapRequest::make_mirror)
    std::string spec;     // the text it was parsed from

    bool diffuse() const { return kd.x > 0 || kd.y > 0 || kd.z > 0; }
    bool specular() const { return ks.x > 0 || ks.y > 0 || ks.z > 0; }
};

// `matte` (kd 1, ks 0), `glossy:N` (kd 0, ks 1, shininess N), `mirror` (kd 0, ks 1, n = infinity)
// or `kd=R,G,B;ks=R,G,B;n=N` (keys in any order; a key left out is 0, n defaults to 1; one number
// stands for all three channels). Throws InputError naming `flag` and the text at fault.
Material parse_material(const std::string& text, const std::string& flag = "--material");

// glTF's metallic-roughness mapped to Phong (docs/render.md, "Materials from glTF"):
//   kd = baseColor (1 - metallic)                 the Lambertian albedo glTF gives the base layer
//   ks = lerp(0.04, baseColor, metallic)          glTF's F0 (Fresnel at normal incidence)
//   alpha = roughness^2,  n = 1 / (2 alpha^2) - 1/2
// n is Blinn-Phong's exponent matched to the GGX/Beckmann width, 2/alpha^2 - 2, divided by 4: the
// conventions' lobe is about R, where angles are twice those about H (measured against GGX in
// docs/render.md). n > 1e5 (roughness < 0.047; a lobe under 0.2 degrees wide, less than a texel of
// a 1024-wide map) becomes the mirror. Fresnel's rise at grazing angles, GGX's energy loss at high
// roughness and textures are not modelled. `spec` says where it came from.
Material material_from_gltf(const GltfMaterial& gltf);

// An OBJ group's MTL material mapped to Phong (docs/render.md, "Several materials"): kd = Kd,
// ks = Ks, n = Ns / 4 (MTL's specular lobe is (N.H)^Ns, about the half vector; the conventions'
// lobe is about R, where angles are twice as large: the same quarter as for glTF). Ks = 0: no
// specular term. `spec` says where it came from. An undefined material is not mapped here.
Material material_from_mtl(const ObjMaterial& mtl);

// The material of each part of the model (Mesh::parts; one for a model without parts):
// `fallback` for every part when `override_all` (--material given), else each glTF part's mapped
// material, each OBJ part's MTL material, and `fallback` for an OBJ part whose material is
// undefined (no MTL, or a name it does not define).
std::vector<Material> part_materials(const Mesh& mesh, const Material& fallback, bool override_all);

// Whether two materials shade identically (the same kd, ks and lobe): one draw for both.
bool same_shading(const Material& a, const Material& b);

// The exponent of the mapping above (infinity below roughness 0.047 means the mirror).
double phong_exponent_from_roughness(double roughness);

// The maps the material shades with, each lobe once: the irradiance map when kd > 0, the Phong
// map of n (or the mirror map) when ks > 0.
std::vector<convolution::MapRequest> needed_maps(const Material& material);
// The distinct lobes of several materials, each once: the irradiance map when any is diffuse,
// then each distinct Phong exponent (or the mirror) of the specular ones.
std::vector<convolution::MapRequest> needed_maps(const std::vector<Material>& materials);
// The reflection map's request of a specular material (its label names the map).
convolution::MapRequest reflection_request(const Material& material);

// "phong_160" for n = 160: the label and file stem `glint convolve --shininess 160` uses.
std::string phong_label(double n);

}  // namespace glint::render
