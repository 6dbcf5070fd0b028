#include "appliance/render/mesh.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <utility>

#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/strict_number.hpp"
#include "appliance/render/teapot.hpp"

namespace glint::render {

Mesh make_uv_sphere(int stacks, int slices) {
    if (stacks < 2 || slices < 3) throw InputError("sphere: needs at least 2 stacks and 3 slices");
    Mesh m;
    m.source = "sphere";
    // Vertices on a (stacks + 1) x (slices + 1) grid; the seam and the poles are duplicated so
    // that every quad has its own corners (the normals are exact, so nothing is averaged).
    for (int j = 0; j <= stacks; ++j) {
        const double theta = kPi * j / stacks;
        for (int i = 0; i <= slices; ++i) {
            const double phi = kTwoPi * i / slices - kPi;
            const glm::vec3 d(direction_from_angles(theta, phi));
            m.positions.push_back(d);
            m.normals.push_back(glm::normalize(d));
        }
    }
    const auto at = [slices](int j, int i) { return std::uint32_t(j * (slices + 1) + i); };
    for (int j = 0; j < stacks; ++j)
        for (int i = 0; i < slices; ++i) {
            // Two triangles per quad; at the poles one of them has two equal corners and is left out.
            if (j != 0) m.indices.insert(m.indices.end(), {at(j, i), at(j + 1, i), at(j, i + 1)});
            if (j != stacks - 1) m.indices.insert(m.indices.end(), {at(j, i + 1), at(j + 1, i), at(j + 1, i + 1)});
        }
    return m;
}

namespace {

std::vector<std::string_view> split_ws(std::string_view line) {
    std::vector<std::string_view> out;
    std::size_t k = 0;
    while (k < line.size()) {
        while (k < line.size() && (line[k] == ' ' || line[k] == '\t' || line[k] == '\r')) ++k;
        std::size_t e = k;
        while (e < line.size() && line[e] != ' ' && line[e] != '\t' && line[e] != '\r') ++e;
        if (e > k) out.push_back(line.substr(k, e - k));
        k = e;
    }
    return out;
}

// An OBJ index (1-based, or negative from the end) into a list of `count`, as 0-based.
std::size_t obj_index(std::string_view text, std::size_t count, const std::string& where, const char* what) {
    const std::int64_t k = parse_int(text, where);
    std::int64_t i = k > 0 ? k - 1 : std::int64_t(count) + k;
    if (k == 0 || i < 0 || i >= std::int64_t(count))
        throw InputError(where + ": " + what + " index " + std::string(text) + " is out of range (" +
                         std::to_string(count) + " defined so far)");
    return std::size_t(i);
}

}  // namespace

// The materials of an MTL file: newmtl, Kd, Ks, Ns (everything else ignored). Throws InputError
// "FILE:LINE: what" on a malformed value; a file that cannot be opened gives no materials.
static std::map<std::string, ObjMaterial> read_mtl(const std::filesystem::path& path) {
    std::map<std::string, ObjMaterial> out;
    std::ifstream in(path);
    if (!in) return out;
    std::string line;
    int line_no = 0;
    ObjMaterial* current = nullptr;
    while (std::getline(in, line)) {
        ++line_no;
        const std::string where = path.string() + ":" + std::to_string(line_no);
        const auto words = split_ws(std::string_view(line).substr(0, line.find('#')));
        if (words.empty()) continue;
        const std::string_view key = words[0];
        if (key == "newmtl") {
            if (words.size() < 2) throw InputError(where + ": newmtl needs a name");
            const std::string name(words[1]);
            current = &out[name];
            current->name = name;
            current->defined = true;
            current->where = path.string();
        } else if (key == "Kd" || key == "Ks" || key == "Ns") {
            if (!current) throw InputError(where + ": '" + std::string(key) + "' before any newmtl");
            if (key == "Ns") {
                if (words.size() != 2) throw InputError(where + ": Ns needs one number");
                current->ns = parse_double(words[1], where);
                if (!(current->ns >= 0)) throw InputError(where + ": Ns must be >= 0");
                continue;
            }
            // Kd r g b, or one number for all three.
            if (words.size() != 2 && words.size() != 4)
                throw InputError(where + ": '" + std::string(key) + "' needs r g b (or one number)");
            glm::dvec3 c(parse_double(words[1], where));
            if (words.size() == 4) c = {parse_double(words[1], where), parse_double(words[2], where), parse_double(words[3], where)};
            if (!(c.x >= 0 && c.y >= 0 && c.z >= 0)) throw InputError(where + ": '" + std::string(key) + "' must be >= 0");
            (key == "Kd" ? current->kd : current->ks) = c;
        }
    }
    return out;
}

Mesh load_obj(const std::filesystem::path& path) {
    std::ifstream in(path);
    if (!in) throw InputError(path.string() + ": cannot open the OBJ file");
    std::vector<glm::vec3> v, vn;
    // Corners keyed by (position, normal or -1): one output vertex each.
    std::map<std::pair<std::size_t, std::int64_t>, std::uint32_t> corners;
    std::vector<std::size_t> corner_position;  // per output vertex
    Mesh m;
    m.source = path.string();
    std::map<std::string, ObjMaterial> library;  // from the mtllib files
    int current_material = -1;                   // into m.obj_materials; -1 before any usemtl
    // Starts a new part when the material of the next faces differs from the last part's.
    const auto note_faces = [&](std::size_t first_index) {
        if (current_material < 0) return;
        if (m.parts.empty() || m.parts.back().material != current_material)
            m.parts.push_back({first_index, 0, current_material});
    };
    std::string line;
    int line_no = 0;
    while (std::getline(in, line)) {
        ++line_no;
        const std::string where = path.string() + ":" + std::to_string(line_no);
        const std::size_t hash = line.find('#');
        const auto words = split_ws(std::string_view(line).substr(0, hash));
        if (words.empty()) continue;
        const std::string_view key = words[0];
        if (key == "v" || key == "vn") {
            // v: x y z, x y z w, or x y z r g b (the common vertex-colour extension; ignored).
            const std::size_t n = words.size() - 1;
            if (key == "vn" ? n != 3 : (n != 3 && n != 4 && n != 6))
                throw InputError(where + ": '" + std::string(key) + "' needs 3 numbers" +
                                 (key == "v" ? " (x y z, x y z w or x y z r g b)" : "") + ", got " + std::to_string(n));
            // Each number must also fit a float: 1e39 parses as a finite double but becomes an
            // infinite coordinate, and every normal and bound computed from it NaN.
            glm::vec3 p;
            for (int c = 0; c < 3; ++c) {
                const double x = parse_double(words[std::size_t(c) + 1], where);
                if (!fits_float(x))
                    throw InputError(where + ": '" + std::string(words[std::size_t(c) + 1]) + "' is beyond a float's range");
                p[c] = float(x);
            }
            if (key == "v") {
                v.push_back(p);
            } else {
                const glm::dvec3 d(p);  // in double: a float's square overflows from 1.8e19
                const double len = glm::length(d);
                if (!(len > 0)) throw InputError(where + ": normal of zero length");
                vn.push_back(glm::vec3(d / len));
            }
        } else if (key == "mtllib") {
            for (std::size_t k = 1; k < words.size(); ++k) {
                // A material library sits beside the model: a model from a USB stick must not
                // make the appliance read /dev/zero or another user's files.
                const std::filesystem::path lib{std::string(words[k])};
                const bool inside = lib.is_relative() && std::none_of(lib.begin(), lib.end(), [](const std::filesystem::path& c) {
                                        return c == "..";
                                    });
                if (!inside) throw InputError(where + ": mtllib '" + lib.string() + "' must be a file in the model's folder");
                for (auto& [name, mat] : read_mtl(path.parent_path() / lib))
                    library.try_emplace(name, mat);  // the first definition of a name wins
            }
        } else if (key == "usemtl") {
            if (words.size() < 2) throw InputError(where + ": usemtl needs a name");
            const std::string name(words[1]);
            if (m.obj_materials.empty() && !m.indices.empty()) {
                // Faces before the first usemtl: a part of their own, with no material.
                m.obj_materials.push_back(ObjMaterial{});
                m.parts.push_back({0, 0, 0});
            }
            auto it = std::find_if(m.obj_materials.begin(), m.obj_materials.end(),
                                   [&](const ObjMaterial& o) { return o.name == name; });
            if (it == m.obj_materials.end()) {
                const auto found = library.find(name);
                ObjMaterial o = found != library.end() ? found->second : ObjMaterial{};
                o.name = name;
                m.obj_materials.push_back(o);
                it = m.obj_materials.end() - 1;
            }
            current_material = int(it - m.obj_materials.begin());
        } else if (key == "f") {
            note_faces(m.indices.size());
            if (words.size() < 4)
                throw InputError(where + ": a face needs at least 3 vertices, got " + std::to_string(words.size() - 1));
            std::vector<std::uint32_t> face;
            for (std::size_t k = 1; k < words.size(); ++k) {
                const std::string_view c = words[k];
                const std::size_t s1 = c.find('/');
                const std::string_view vs = c.substr(0, s1);
                std::int64_t ni = -1;
                if (s1 != std::string_view::npos) {
                    const std::size_t s2 = c.find('/', s1 + 1);
                    if (s2 != std::string_view::npos) {
                        const std::string_view ns = c.substr(s2 + 1);
                        if (!ns.empty()) ni = std::int64_t(obj_index(ns, vn.size(), where, "normal"));
                    }
                }
                if (vs.empty()) throw InputError(where + ": face corner '" + std::string(c) + "' has no position");
                const std::size_t vi = obj_index(vs, v.size(), where, "vertex");
                const auto [it, inserted] = corners.try_emplace({vi, ni}, std::uint32_t(m.positions.size()));
                if (inserted) {
                    m.positions.push_back(v[vi]);
                    m.normals.push_back(ni >= 0 ? vn[std::size_t(ni)] : glm::vec3(0));
                    corner_position.push_back(vi);
                }
                face.push_back(it->second);
            }
            for (std::size_t k = 1; k + 1 < face.size(); ++k)
                m.indices.insert(m.indices.end(), {face[0], face[k], face[k + 1]});
        }
    }
    if (in.bad()) throw InputError(path.string() + ": read error");
    if (m.indices.empty()) throw InputError(path.string() + ": no faces ('f' lines) in the OBJ file");
    // Each part runs to the next one's start (faces of one part are consecutive in the file's order).
    for (std::size_t k = 0; k < m.parts.size(); ++k)
        m.parts[k].index_count = (k + 1 < m.parts.size() ? m.parts[k + 1].first_index : m.indices.size()) - m.parts[k].first_index;
    std::erase_if(m.parts, [](const MeshPart& p) { return p.index_count == 0; });

    // Corners without a normal (left at 0 above): area-weighted face normals per position.
    fill_missing_normals(m, corner_position, v.size());
    return m;
}

void fill_missing_normals(Mesh& mesh, const std::vector<std::size_t>& position_of, std::size_t position_count) {
    std::vector<glm::dvec3> sum(position_count, glm::dvec3(0));
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
        const glm::dvec3 a(mesh.positions[mesh.indices[t]]), b(mesh.positions[mesh.indices[t + 1]]),
            c(mesh.positions[mesh.indices[t + 2]]);
        const glm::dvec3 n = glm::cross(b - a, c - a);  // length = 2 * area
        for (int k = 0; k < 3; ++k) sum[position_of[mesh.indices[t + std::size_t(k)]]] += n;
    }
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
        if (mesh.normals[i] != glm::vec3(0)) continue;
        const glm::dvec3 n = sum[position_of[i]];
        const double len = glm::length(n);
        // A position only on degenerate faces keeps an arbitrary unit normal.
        mesh.normals[i] = len > 0 ? glm::vec3(n / len) : glm::vec3(0, 1, 0);
    }
}

bool model_is_file(const std::string& spec) {
    return !(spec == "sphere" || spec == "teapot" || spec.rfind("teapot:", 0) == 0);
}

Mesh load_model(const std::string& spec, const std::string& flag) {
    if (spec == "sphere") return make_uv_sphere();
    if (!model_is_file(spec)) {
        // teapot:LEVEL picks the tessellation (teapot:40 is the benchmark's ~100k triangles).
        const int level = spec == "teapot" ? kTeapotDefaultLevel
                                           : int(parse_int(std::string_view(spec).substr(7), flag + " " + spec));
        if (level < 1 || level > 400)
            throw InputError(flag + " " + spec + ": the teapot's level must be in [1, 400] (400: 10 million triangles)");
        Mesh mesh = make_teapot(level);
        normalise_to_unit_sphere(mesh);
        return mesh;
    }
    const std::filesystem::path path(spec);
    std::string ext = path.extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    Mesh mesh;
    if (ext == ".obj") mesh = load_obj(path);
    else if (ext == ".gltf" || ext == ".glb") mesh = load_gltf(path);
    else throw InputError(flag + " " + spec + ": want sphere, teapot, teapot:LEVEL, an .obj, .gltf or .glb file");
    normalise_to_unit_sphere(mesh);
    return mesh;
}

bool ray_crosses_triangle(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& a, const glm::dvec3& b,
                          const glm::dvec3& c, double t_min) {
    const glm::dvec3 e1 = b - a, e2 = c - a, p = glm::cross(d, e2);
    const double det = glm::dot(e1, p);
    if (std::abs(det) < 1e-14) return false;  // the ray runs in the triangle's plane
    const glm::dvec3 s = o - a;
    const double u = glm::dot(s, p) / det;
    if (u < 0 || u > 1) return false;
    const glm::dvec3 q = glm::cross(s, e1);
    const double v = glm::dot(d, q) / det;
    if (v < 0 || u + v > 1) return false;
    return glm::dot(e2, q) / det > t_min;
}

MeshBounds mesh_bounds(const Mesh& mesh) {
    MeshBounds b;
    if (mesh.positions.empty()) return b;
    b.lo = b.hi = glm::dvec3(mesh.positions[0]);
    for (const auto& p : mesh.positions) {
        b.lo = glm::min(b.lo, glm::dvec3(p));
        b.hi = glm::max(b.hi, glm::dvec3(p));
    }
    b.centre = 0.5 * (b.lo + b.hi);
    for (const auto& p : mesh.positions) b.radius = std::max(b.radius, glm::length(glm::dvec3(p) - b.centre));
    return b;
}

void normalise_to_unit_sphere(Mesh& mesh) {
    if (mesh.positions.empty()) return;
    // In double: float coordinates up to 3.4e38 overflow lo + hi and any length past 1.8e19.
    const MeshBounds b = mesh_bounds(mesh);
    const double scale = b.radius > 0 ? 1.0 / b.radius : 1.0;
    for (auto& p : mesh.positions) p = glm::vec3((glm::dvec3(p) - b.centre) * scale);
}

}  // namespace glint::render
