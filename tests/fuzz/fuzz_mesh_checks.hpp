// The invariants every loaded Mesh keeps (appliance/render/mesh.hpp), checked by the OBJ and glTF
// fuzz targets on whatever they accept: the renderer indexes its buffers with them unchecked.
#pragma once

#include <cmath>

#include "appliance/render/mesh.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace glint::fuzz {

inline void check_mesh(const render::Mesh& m) {
    check(!m.indices.empty() && m.indices.size() % 3 == 0);
    check(m.normals.size() == m.positions.size());
    for (const std::uint32_t i : m.indices) check(i < m.positions.size());
    for (const auto& p : m.positions) check(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
    for (const auto& n : m.normals) check(std::isfinite(n.x) && std::isfinite(n.y) && std::isfinite(n.z));
    for (const auto& part : m.parts) {
        check(part.first_index % 3 == 0 && part.index_count % 3 == 0);
        check(part.first_index + part.index_count <= m.indices.size());
        check(part.material >= 0);
    }
}

}  // namespace glint::fuzz
