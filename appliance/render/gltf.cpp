// glTF 2.0 meshes through Debian's TinyGLTF (libtinygltf-dev, a shared library: nothing here
// defines TINYGLTF_IMPLEMENTATION).
#include <tiny_gltf.h>

#include <algorithm>
#include <cstring>
#include <exception>
#include <functional>
#include <initializer_list>
#include <new>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "appliance/core/errors.hpp"
#include "appliance/render/mesh.hpp"

namespace glint::render {
namespace {

// The node's local transform: its matrix, or translation * rotation * scale (glTF 2.0, 5.25).
glm::dmat4 local_transform(const tinygltf::Node& node) {
    if (node.matrix.size() == 16) return glm::make_mat4(node.matrix.data());  // column-major, as GLM
    glm::dmat4 m(1.0);
    if (node.translation.size() == 3)
        m = glm::translate(m, glm::dvec3(node.translation[0], node.translation[1], node.translation[2]));
    if (node.rotation.size() == 4)  // x, y, z, w
        m *= glm::mat4_cast(glm::dquat(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]));
    if (node.scale.size() == 3) m = glm::scale(m, glm::dvec3(node.scale[0], node.scale[1], node.scale[2]));
    return m;
}

bool finite_float(const glm::dvec3& p) { return fits_float(p.x) && fits_float(p.y) && fits_float(p.z); }

class Reader {
public:
    Reader(const tinygltf::Model& model, const std::string& file) : model_(model), file_(file) {}

    // Element k of an accessor as `n` doubles (float or unsigned integer components).
    template <typename F>
    void read(int accessor_index, int want_components, const char* what, F&& each) const {
        if (accessor_index < 0 || accessor_index >= int(model_.accessors.size()))
            fail(std::string(what) + ": no accessor " + std::to_string(accessor_index));
        const tinygltf::Accessor& a = model_.accessors[std::size_t(accessor_index)];
        if (a.sparse.isSparse) fail(std::string(what) + ": sparse accessors are not supported");
        if (a.bufferView < 0 || a.bufferView >= int(model_.bufferViews.size()))
            fail(std::string(what) + ": accessor without a buffer view");
        const int components = tinygltf::GetNumComponentsInType(std::uint32_t(a.type));
        if (components != want_components)
            fail(std::string(what) + ": want " + std::to_string(want_components) + " components, got " +
                 std::to_string(components));
        const int size = tinygltf::GetComponentSizeInBytes(std::uint32_t(a.componentType));
        if (size <= 0) fail(std::string(what) + ": unknown component type");
        const tinygltf::BufferView& view = model_.bufferViews[std::size_t(a.bufferView)];
        if (view.buffer < 0 || view.buffer >= int(model_.buffers.size())) fail(std::string(what) + ": no buffer");
        const std::vector<unsigned char>& data = model_.buffers[std::size_t(view.buffer)].data;
        const std::size_t element = std::size_t(size) * std::size_t(components);
        const std::size_t stride = view.byteStride ? view.byteStride : element;
        if (stride < element)
            fail(std::string(what) + ": byteStride " + std::to_string(stride) + " is less than an element's " +
                 std::to_string(element) + " bytes");
        // Every offset and count comes from the file as any 64-bit number: compared by subtraction,
        // so that no sum can wrap round and pass.
        const bool inside = view.byteOffset <= data.size() && view.byteLength <= data.size() - view.byteOffset &&
                            a.byteOffset <= view.byteLength && element <= view.byteLength - a.byteOffset &&
                            (a.count == 0 || a.count - 1 <= (view.byteLength - a.byteOffset - element) / stride);
        if (!inside) fail(std::string(what) + ": accessor reads past its buffer");
        const std::size_t begin = view.byteOffset + a.byteOffset;
        double v[4];
        for (std::size_t k = 0; k < a.count; ++k) {
            const unsigned char* p = data.data() + begin + stride * k;
            for (int c = 0; c < components; ++c) {
                const unsigned char* q = p + std::size_t(c * size);
                switch (a.componentType) {
                    case TINYGLTF_COMPONENT_TYPE_FLOAT: { float f; std::memcpy(&f, q, 4); v[c] = f; break; }
                    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: v[c] = *q; break;
                    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: { std::uint16_t u; std::memcpy(&u, q, 2); v[c] = u; break; }
                    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { std::uint32_t u; std::memcpy(&u, q, 4); v[c] = u; break; }
                    default: fail(std::string(what) + ": component type " + std::to_string(a.componentType) + " is not supported");
                }
            }
            each(k, v);
        }
    }
    // Whether the accessor's components are of one of `types` (false for no such accessor).
    bool of_type(int accessor_index, std::initializer_list<int> types) const {
        if (accessor_index < 0 || accessor_index >= int(model_.accessors.size())) return false;
        const int type = model_.accessors[std::size_t(accessor_index)].componentType;
        return std::find(types.begin(), types.end(), type) != types.end();
    }
    std::size_t count(int accessor_index) const {
        return accessor_index >= 0 && accessor_index < int(model_.accessors.size())
                   ? model_.accessors[std::size_t(accessor_index)].count : 0;
    }
    [[noreturn]] void fail(const std::string& what) const { throw InputError(file_ + ": " + what); }

private:
    const tinygltf::Model& model_;
    std::string file_;
};

// TinyGLTF opens a .gltf file's buffer and image URIs as paths. A model from a USB stick must not
// make the appliance read files outside the model's folder ("../../etc/shadow", "/dev/zero"), as
// the OBJ reader's mtllib is held to it: every file TinyGLTF asks for is resolved and checked.
struct ModelFolder {
    std::filesystem::path dir;  // canonical
    bool holds(const std::string& file) const {
        if (dir.empty()) return false;  // the folder itself could not be resolved
        std::error_code ec;
        const std::filesystem::path p = std::filesystem::weakly_canonical(file, ec);
        if (ec) return false;
        const auto [end, _] = std::mismatch(dir.begin(), dir.end(), p.begin(), p.end());
        return end == dir.end();
    }
};

tinygltf::FsCallbacks confined_to(const ModelFolder& folder) {
    tinygltf::FsCallbacks fs{};
    fs.user_data = const_cast<ModelFolder*>(&folder);
    // Whether a file exists is not confined, so that the read below names the reason.
    fs.FileExists = [](const std::string& file, void*) { return tinygltf::FileExists(file, nullptr); };
    fs.ExpandFilePath = [](const std::string& file, void*) { return file; };  // no ~ or $VAR
    fs.ReadWholeFile = [](std::vector<unsigned char>* out, std::string* err, const std::string& file, void* user) {
        if (!static_cast<const ModelFolder*>(user)->holds(file)) {
            if (err) *err += "'" + file + "' is outside the model's folder";
            return false;
        }
        return tinygltf::ReadWholeFile(out, err, file, nullptr);
    };
    fs.WriteWholeFile = [](std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
        if (err) *err += "writing is not allowed";
        return false;
    };
    return fs;
}

}  // namespace

Mesh load_gltf(const std::filesystem::path& path) {
    tinygltf::TinyGLTF loader;
    std::error_code folder_error;
    const ModelFolder folder{std::filesystem::weakly_canonical(std::filesystem::absolute(path).parent_path(), folder_error)};
    loader.SetFsCallbacks(confined_to(folder));
    tinygltf::Model model;
    std::string err, warn;
    const std::string file = path.string();
    const bool binary = path.extension() == ".glb";
    bool ok = false;
    try {
        ok = binary ? loader.LoadBinaryFromFile(&model, &err, &warn, file)
                    : loader.LoadASCIIFromFile(&model, &err, &warn, file);
    } catch (const std::bad_alloc&) {
        throw;
    } catch (const std::exception& e) {
        // TinyGLTF reports most damage in `err`, but some it meets through the standard library:
        // a binary file whose buffer says 0 bytes beside a BIN chunk threw std::out_of_range
        // from inside the loader (the glTF fuzzer, 2026-12-06). A damaged file either way.
        err = e.what();
        ok = false;
    }
    if (!ok) {
        while (!err.empty() && (err.back() == '\n' || err.back() == '\r')) err.pop_back();
        for (char& c : err)
            if (c == '\n') c = ' ';
        throw InputError(file + ": not a readable glTF 2.0 file: " + (err.empty() ? "unknown error" : err));
    }
    const Reader reader(model, file);
    Mesh mesh;
    mesh.source = file;
    std::vector<std::size_t> position_of;
    int skipped = 0;

    // The materials the triangles use, each once, in order of first use (-1: glTF's default).
    // Returns the material's index in mesh.materials.
    std::vector<int> used_materials;
    const auto use_material = [&](int k) -> int {
        if (k >= int(model.materials.size())) reader.fail("a primitive names no material " + std::to_string(k));
        const auto seen = std::find(used_materials.begin(), used_materials.end(), k);
        if (seen != used_materials.end()) return int(seen - used_materials.begin());
        used_materials.push_back(k);
        GltfMaterial g;
        if (k < 0) {
            g.name = "default";
        } else {
            const tinygltf::Material& m = model.materials[std::size_t(k)];
            const tinygltf::PbrMetallicRoughness& pbr = m.pbrMetallicRoughness;
            g.name = m.name.empty() ? "material " + std::to_string(k) : m.name;
            if (pbr.baseColorFactor.size() >= 3) g.base_color = {pbr.baseColorFactor[0], pbr.baseColorFactor[1], pbr.baseColorFactor[2]};
            g.metallic = pbr.metallicFactor;
            g.roughness = pbr.roughnessFactor;
            g.textured = pbr.baseColorTexture.index >= 0 || pbr.metallicRoughnessTexture.index >= 0;
            for (double c : {g.base_color.x, g.base_color.y, g.base_color.z, g.metallic, g.roughness})
                if (!(c >= 0.0 && c <= 1.0)) reader.fail("material '" + g.name + "': a factor outside [0, 1]");
        }
        mesh.materials.push_back(g);
        return int(mesh.materials.size()) - 1;
    };

    const auto add_mesh = [&](int mesh_index, const glm::dmat4& world) {
        if (mesh_index < 0 || mesh_index >= int(model.meshes.size())) reader.fail("node names no mesh " + std::to_string(mesh_index));
        const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(glm::dmat3(world)));
        for (const tinygltf::Primitive& prim : model.meshes[std::size_t(mesh_index)].primitives) {
            if (prim.mode != -1 && prim.mode != TINYGLTF_MODE_TRIANGLES) {
                ++skipped;
                continue;
            }
            const auto pos = prim.attributes.find("POSITION");
            if (pos == prim.attributes.end()) reader.fail("a primitive has no POSITION");
            const std::size_t base = mesh.positions.size();
            const std::size_t n = reader.count(pos->second);
            // Quantised attributes (KHR_mesh_quantization: normalised or integer components) are
            // not supported: read as plain integers they would be finite but wrong.
            if (!reader.of_type(pos->second, {TINYGLTF_COMPONENT_TYPE_FLOAT})) reader.fail("POSITION: accessor " + std::to_string(pos->second) + " is not of floats");
            reader.read(pos->second, 3, "POSITION", [&](std::size_t k, const double* v) {
                // A NaN or infinite coordinate (garbage bytes, or a node transform that scales past
                // a float's range) would make every normal and bound computed from it NaN.
                const glm::dvec3 p(world * glm::dvec4(v[0], v[1], v[2], 1.0));
                if (!finite_float(p))
                    reader.fail("POSITION " + std::to_string(k) + " of accessor " + std::to_string(pos->second) +
                                (finite_float(glm::dvec3(v[0], v[1], v[2])) ? " is beyond a float's range after its node's transform"
                                                                           : " is not a finite number"));
                mesh.positions.push_back(glm::vec3(p));
                mesh.normals.push_back(glm::vec3(0));
                position_of.push_back(position_of.size());
            });
            const auto nor = prim.attributes.find("NORMAL");
            if (nor != prim.attributes.end()) {
                if (reader.count(nor->second) != n) reader.fail("NORMAL and POSITION counts differ");
                if (!reader.of_type(nor->second, {TINYGLTF_COMPONENT_TYPE_FLOAT})) reader.fail("NORMAL: accessor " + std::to_string(nor->second) + " is not of floats");
                reader.read(nor->second, 3, "NORMAL", [&](std::size_t k, const double* v) {
                    if (!finite_float(glm::dvec3(v[0], v[1], v[2])))
                        reader.fail("NORMAL " + std::to_string(k) + " of accessor " + std::to_string(nor->second) +
                                    " is not a finite number");
                    // A singular transform (a scale of 0) has no normal matrix: such normals, and
                    // zero-length ones, are left at 0 and filled from the faces below.
                    const glm::dvec3 d = normal_matrix * glm::dvec3(v[0], v[1], v[2]);
                    const double len = glm::length(d);
                    mesh.normals[base + k] = std::isfinite(len) && len > 0 ? glm::vec3(d / len) : glm::vec3(0);
                });
            }
            const std::size_t first_index = mesh.indices.size();
            if (prim.indices >= 0) {
                // glTF 2.0 (3.7.2.1): indices are unsigned bytes, shorts or ints, never floats.
                if (!reader.of_type(prim.indices, {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                                   TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT}))
                    reader.fail("indices: accessor " + std::to_string(prim.indices) + " is not of unsigned integers");
                reader.read(prim.indices, 1, "indices", [&](std::size_t, const double* v) {
                    if (v[0] >= double(n)) reader.fail("index " + std::to_string(std::uint64_t(v[0])) + " >= " + std::to_string(n) + " vertices");
                    mesh.indices.push_back(std::uint32_t(base + std::size_t(v[0])));
                });
            } else {
                for (std::size_t k = 0; k < n; ++k) mesh.indices.push_back(std::uint32_t(base + k));
            }
            if ((mesh.indices.size() - first_index) % 3 != 0) reader.fail("a triangle list whose index count is not a multiple of 3");
            if (mesh.indices.size() > first_index) {
                // A part per primitive; consecutive primitives of one material merge.
                const int material = use_material(prim.material);
                if (!mesh.parts.empty() && mesh.parts.back().material == material)
                    mesh.parts.back().index_count += mesh.indices.size() - first_index;
                else
                    mesh.parts.push_back({first_index, mesh.indices.size() - first_index, material});
            }
        }
    };

    // glTF 2.0 (3.5.3): the nodes form disjoint strict trees, so each is visited once. A node named
    // twice would be drawn twice, and a chain of nodes each naming the next twice 2^depth times.
    std::vector<bool> visited(model.nodes.size(), false);
    const std::function<void(int, const glm::dmat4&, int)> visit = [&](int node_index, const glm::dmat4& parent, int depth) {
        if (node_index < 0 || node_index >= int(model.nodes.size())) reader.fail("no node " + std::to_string(node_index));
        if (visited[std::size_t(node_index)])
            reader.fail("node " + std::to_string(node_index) + " has more than one parent (or is in a cycle)");
        visited[std::size_t(node_index)] = true;
        if (depth > 256) reader.fail("the node tree is deeper than 256");
        const tinygltf::Node& node = model.nodes[std::size_t(node_index)];
        const glm::dmat4 world = parent * local_transform(node);
        if (node.mesh >= 0) add_mesh(node.mesh, world);
        for (int child : node.children) visit(child, world, depth + 1);
    };
    if (!model.scenes.empty()) {
        const int scene = model.defaultScene >= 0 && model.defaultScene < int(model.scenes.size()) ? model.defaultScene : 0;
        for (int node : model.scenes[std::size_t(scene)].nodes) visit(node, glm::dmat4(1.0), 0);
    } else {
        for (int k = 0; k < int(model.meshes.size()); ++k) add_mesh(k, glm::dmat4(1.0));
    }
    if (mesh.indices.empty())
        reader.fail(skipped > 0 ? "no triangle lists (" + std::to_string(skipped) + " primitives of other modes skipped)"
                                : "no triangles in the default scene");
    fill_missing_normals(mesh, position_of, position_of.size());
    return mesh;
}

}  // namespace glint::render
