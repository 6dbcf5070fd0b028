// Triangle meshes for the renderer: a procedural UV sphere and OBJ files (docs/render.md).
// Positions and normals are in the model's own frame; the renderer places the model so that its
// bounding sphere is the unit sphere at the world origin (normalise_to_unit_sphere).
#pragma once

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace glint::render {

// A glTF material's metallic-roughness factors (glTF 2.0, "pbrMetallicRoughness"), as read;
// material.hpp maps them to Phong. Textures are not read (`textured` says one was named).
struct GltfMaterial {
    std::string name;                 // the material's name, or "material K", or "default"
    glm::dvec3 base_color{1.0};       // baseColorFactor's RGB (linear); alpha is ignored
    double metallic = 1.0;            // metallicFactor
    double roughness = 1.0;           // roughnessFactor
    bool textured = false;            // a base-colour or metallic-roughness texture was named (ignored)
};

// A material an OBJ file names with `usemtl`, as its MTL file (`mtllib`) defines it: Kd, Ks, Ns
// (material.hpp maps them to Phong). `defined` is false when no MTL file read defines the name
// (or there was none): such a group is shaded with --material.
struct ObjMaterial {
    std::string name;  // the usemtl name; "" for faces before any usemtl
    bool defined = false;
    glm::dvec3 kd{0.0}, ks{0.0};
    double ns = 0.0;
    std::string where;  // "FILE.mtl" that defined it, for messages
};

// A run of triangles that share one material: indices [first_index, first_index + index_count)
// of Mesh::indices; `material` indexes Mesh::materials (glTF) or Mesh::obj_materials (OBJ).
struct MeshPart {
    std::size_t first_index = 0, index_count = 0;
    int material = 0;
};

struct Mesh {
    std::vector<glm::vec3> positions;
    std::vector<glm::vec3> normals;      // one per position, unit length
    std::vector<std::uint32_t> indices;  // three per triangle
    std::string source;                  // "sphere", or the file it came from
    // Baked ambient occlusion, one per position in [0, 1] (ao_bake.hpp, ao_file.hpp); empty means
    // ao = 1 everywhere (the sphere, a model without a matching .ao file, --no-ao).
    std::vector<float> ao;
    // glTF only: the materials of the triangles read, in order of first use (a primitive without
    // a material uses glTF's default: base colour 1, metallic 1, roughness 1). Empty for OBJ.
    std::vector<GltfMaterial> materials;
    // OBJ only: the usemtl groups' materials, in order of first use (empty without usemtl).
    std::vector<ObjMaterial> obj_materials;
    // The triangles of each material (glTF primitives, OBJ usemtl groups), consecutive runs
    // merged; empty for a model with one material and nothing to say about it (sphere, teapot,
    // an OBJ without usemtl): all triangles are one part shaded with --material.
    std::vector<MeshPart> parts;

    std::size_t triangle_count() const { return indices.size() / 3; }
};

// A UV sphere of radius 1 at the origin: `stacks` rings from pole to pole, `slices` around the
// +Y axis; the normals are the exact sphere normals (not averaged faces).
Mesh make_uv_sphere(int stacks = 96, int slices = 192);

// A Wavefront OBJ file: `v` (x y z, optionally w or r g b, which are ignored), `vn`, and `f` with any of the forms v, v/vt, v//vn,
// v/vt/vn (negative indices count back from the end); polygons are triangulated as fans. Corners
// without a normal get the area-weighted mean of the normals of the faces around their position.
// `mtllib` files (beside the OBJ) are read for `newmtl`, `Kd`, `Ks`, `Ns`; `usemtl` starts a part
// (Mesh::parts, Mesh::obj_materials). A missing MTL file or name leaves the material undefined.
// Every other statement (vt, o, g, s, l, p, ...) is ignored. Throws InputError
// "FILE:LINE: what" on a malformed line, an index out of range or a file without faces.
Mesh load_obj(const std::filesystem::path& path);

// A glTF 2.0 file (.gltf with its buffers, or .glb) through Debian's TinyGLTF: the triangles of
// every mesh of the default scene (the first scene, or every mesh when there is none), each placed
// by its node's transform (matrix or translation, rotation, scale, down the node tree). POSITION
// and, when present, NORMAL (float VEC3); indices of any unsigned type or none. Primitives that are
// not triangle lists are skipped. The metallic-roughness factors of the primitives' materials go
// to Mesh::materials (textures are not read).
// Vertices without normals get area-weighted face normals. Throws InputError naming the file.
Mesh load_gltf(const std::filesystem::path& path);

// Gives every vertex whose normal is (0, 0, 0) the area-weighted mean of the normals of the
// triangles around its position (`position_of[v]`: the position shared by vertex v's corners).
void fill_missing_normals(Mesh& mesh, const std::vector<std::size_t>& position_of, std::size_t position_count);

// A model as `--model` names it: "sphere", "teapot" (teapot.hpp, level 16), "teapot:LEVEL", or
// an .obj, .gltf or .glb file; normalised into the unit sphere. Throws InputError naming `flag`.
Mesh load_model(const std::string& spec, const std::string& flag = "--model");

// Whether `spec` names a file (not one of the built-in models).
bool model_is_file(const std::string& spec);

// Moller-Trumbore: does the ray o + t d cross triangle (a, b, c) at some t > t_min?
bool ray_crosses_triangle(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& a, const glm::dvec3& b,
                          const glm::dvec3& c, double t_min = 0.0);

// The mesh's axis-aligned bounding box and the sphere about the box's centre through its
// farthest vertex (the size the bakes measure their distances and grids in). Empty mesh: zeros.
struct MeshBounds {
    glm::dvec3 lo{0.0}, hi{0.0}, centre{0.0};
    double radius = 0;
};
MeshBounds mesh_bounds(const Mesh& mesh);

// Whether a coordinate read as a double is finite and within a float's range (the mesh stores
// floats: 1e39 would become infinite, and every normal and bound computed from it NaN).
inline bool fits_float(double x) { return std::abs(x) <= double(std::numeric_limits<float>::max()); }  // false for NaN

// Moves and scales the mesh so that its axis-aligned bounding box is centred on the origin and
// the farthest vertex is at distance 1 (the camera of renderer.hpp frames the unit sphere).
void normalise_to_unit_sphere(Mesh& mesh);

}  // namespace glint::render
