// Low-discrepancy sampling helpers shared by the Embree bakes (ambient occlusion, table shadows).
#pragma once

#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>

namespace glint::render {

// Radical inverse in base 2: the second coordinate of a Hammersley set.
inline double radical_inverse(std::uint32_t k) {
    k = (k << 16) | (k >> 16);
    k = ((k & 0x55555555u) << 1) | ((k & 0xAAAAAAAAu) >> 1);
    k = ((k & 0x33333333u) << 2) | ((k & 0xCCCCCCCCu) >> 2);
    k = ((k & 0x0F0F0F0Fu) << 4) | ((k & 0xF0F0F0F0u) >> 4);
    k = ((k & 0x00FF00FFu) << 8) | ((k & 0xFF00FF00u) >> 8);
    return double(k) * 0x1.0p-32;
}

// An orthonormal basis (t, b, n) with n as its third axis (Duff et al., "Building an Orthonormal
// Basis, Revisited", JCGT 2017): no branch on a chosen helper axis, continuous except at the
// sign change of n.z.
inline void orthonormal_basis(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& b) {
    const double s = std::copysign(1.0, n.z);
    const double a = -1.0 / (s + n.z);
    const double c = n.x * n.y * a;
    t = glm::dvec3(1.0 + s * n.x * n.x * a, s * c, -s * n.x);
    b = glm::dvec3(c, s + n.y * n.y * a, -n.y);
}

}  // namespace glint::render
