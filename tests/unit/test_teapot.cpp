// The Newell teapot (appliance/render/teapot.hpp): its data, its tessellation, its normals.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include "appliance/core/errors.hpp"
#include "appliance/render/teapot.hpp"

namespace glint::render {
namespace {

// A position rounded to 1e-5 (patch seams are evaluated from the same control points).
using Key = std::tuple<long, long, long>;
Key key_of(const glm::vec3& p) {
    return {std::lround(double(p.x) * 1e5), std::lround(double(p.y) * 1e5), std::lround(double(p.z) * 1e5)};
}

// Tessellates only the given patches (indices into teapot_patches) by taking their triangles out
// of the whole model: make_teapot lays patches out one after another, (level+1)^2 vertices each.
struct Subset {
    std::vector<glm::vec3> positions;
    std::vector<std::array<std::uint32_t, 3>> triangles;
};

Subset subset(const Mesh& m, int level, const std::set<int>& patches) {
    const std::uint32_t per_patch = std::uint32_t((level + 1) * (level + 1));
    Subset s;
    s.positions = m.positions;
    for (std::size_t t = 0; t < m.indices.size(); t += 3)
        if (patches.count(int(m.indices[t] / per_patch)))
            s.triangles.push_back({m.indices[t], m.indices[t + 1], m.indices[t + 2]});
    return s;
}

// Edges used by exactly one triangle after welding equal positions.
std::size_t boundary_edges(const Subset& s, std::vector<glm::vec3>* ends = nullptr) {
    std::map<Key, int> id;
    std::vector<glm::vec3> where;
    std::vector<int> welded(s.positions.size());
    for (std::size_t i = 0; i < s.positions.size(); ++i) {
        const auto [it, fresh] = id.try_emplace(key_of(s.positions[i]), int(where.size()));
        if (fresh) where.push_back(s.positions[i]);
        welded[i] = it->second;
    }
    std::map<std::pair<int, int>, int> uses;
    for (const auto& t : s.triangles)
        for (int k = 0; k < 3; ++k) {
            int a = welded[t[std::size_t(k)]], b = welded[t[std::size_t((k + 1) % 3)]];
            if (a > b) std::swap(a, b);
            ++uses[{a, b}];
        }
    std::size_t count = 0;
    for (const auto& [edge, n] : uses)
        if (n == 1) {
            ++count;
            if (ends) {
                ends->push_back(where[std::size_t(edge.first)]);
                ends->push_back(where[std::size_t(edge.second)]);
            }
        }
    return count;
}

const std::set<int> kRim{0, 1, 2, 3}, kBody{4, 5, 6, 7, 8, 9, 10, 11}, kHandle{12, 13, 14, 15},
    kSpout{16, 17, 18, 19}, kLid{20, 21, 22, 23, 24, 25, 26, 27}, kBottom{28, 29, 30, 31};

TEST(Teapot, DataIsMirrorSymmetricAndIndicesAreInRange) {
    const auto& points = teapot_control_points();
    std::set<std::tuple<double, double, double>> set;
    for (const auto& p : points) set.insert({p.x, p.y, p.z});
    // The pot is symmetric about Newell's y = 0 plane; a mistyped point has no mirror image.
    for (const auto& p : points) EXPECT_TRUE(set.count({p.x, p.y == 0 ? 0.0 : -p.y, p.z})) << p.x << " " << p.y << " " << p.z;
    std::set<int> used;
    for (const auto& patch : teapot_patches())
        for (int i : patch) {
            ASSERT_GE(i, 0);
            ASSERT_LT(i, 306);
            used.insert(i);
        }
    EXPECT_EQ(used.size(), 302u);  // all but the original's points 205, 206, 216 and 223
}

TEST(Teapot, TriangleCountFollowsTheLevel) {
    for (int level : {1, 3, 8, 16}) {
        const Mesh m = make_teapot(level);
        EXPECT_EQ(m.triangle_count(), teapot_triangle_count(level)) << level;
        EXPECT_EQ(m.triangle_count(), std::size_t(64 * level * level - 8 * level)) << level;
        EXPECT_EQ(m.positions.size(), std::size_t(32 * (level + 1) * (level + 1)));
    }
    // The benchmark's model of about 100k triangles.
    EXPECT_EQ(teapot_triangle_count(40), 102080u);
    EXPECT_THROW(make_teapot(0), InputError);
}

TEST(Teapot, NoDegenerateTriangles) {
    const Mesh m = make_teapot(12);
    for (std::size_t t = 0; t < m.indices.size(); t += 3) {
        const glm::dvec3 a(m.positions[m.indices[t]]), b(m.positions[m.indices[t + 1]]), c(m.positions[m.indices[t + 2]]);
        ASSERT_GT(glm::length(glm::cross(b - a, c - a)), 1e-10) << "triangle " << t / 3;
    }
}

// Welded, the pot's surfaces of revolution (rim, body, lid, bottom) are closed except for the two
// circles at the lid's opening, y = 2.4: the rim's inner edge (radius 1.4) and the lid's outer
// edge (radius 1.3), level edges on each of 4 patches. The handle and the spout are tubes open at
// both ends. A mistyped shared control point opens a seam and changes these counts.
TEST(Teapot, PatchSeamsAreClosed) {
    const int level = 10;
    const Mesh m = make_teapot(level);
    std::set<int> pot = kRim;
    pot.insert(kBody.begin(), kBody.end());
    pot.insert(kLid.begin(), kLid.end());
    pot.insert(kBottom.begin(), kBottom.end());
    std::vector<glm::vec3> ends;
    EXPECT_EQ(boundary_edges(subset(m, level, pot), &ends), std::size_t(8 * level));
    for (const auto& p : ends) {
        EXPECT_NEAR(p.y, 2.4f, 1e-5f);
        const float r = std::hypot(p.x, p.z);
        // A Bezier quarter circle is within 0.03 % of the circle.
        EXPECT_TRUE(std::abs(r - 1.4f) < 0.01f || std::abs(r - 1.3f) < 0.01f) << r;
    }
    EXPECT_EQ(boundary_edges(subset(m, level, kHandle)), std::size_t(4 * level));
    EXPECT_EQ(boundary_edges(subset(m, level, kSpout)), std::size_t(4 * level));
}

// A crossing beyond the ray's own start (the ray starts on the surface).
bool hits(const glm::dvec3& o, const glm::dvec3& d, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
    return ray_crosses_triangle(o, d, a, b, c, 1e-6);
}

TEST(Teapot, NormalsAreUnitAndPointOutOfThePot) {
    const int level = 6;
    const Mesh m = make_teapot(level);
    for (const auto& n : m.normals) ASSERT_NEAR(glm::length(n), 1.0f, 1e-5f);
    // Normals agree with the triangles' winding (counter-clockwise seen from outside).
    for (std::size_t t = 0; t < m.indices.size(); t += 3) {
        const glm::dvec3 a(m.positions[m.indices[t]]), b(m.positions[m.indices[t + 1]]), c(m.positions[m.indices[t + 2]]);
        const glm::dvec3 face = glm::normalize(glm::cross(b - a, c - a));
        for (int k = 0; k < 3; ++k) EXPECT_GT(glm::dot(face, glm::dvec3(m.normals[m.indices[t + std::size_t(k)]])), 0.0);
    }
    // Outward: a ray along the normal from a point just off the surface crosses the mesh an even
    // number of times. Per patch, most vertices must pass (parts of the spout and handle that lie
    // inside the body, and rays grazing a seam, may not).
    const std::size_t per_patch = std::size_t((level + 1) * (level + 1));
    for (std::size_t patch = 0; patch < 32; ++patch) {
        int outward = 0, total = 0;
        for (std::size_t v = patch * per_patch; v < (patch + 1) * per_patch; ++v) {
            const glm::dvec3 n(m.normals[v]);
            // A direction slightly off the normal, so that the ray does not run along a seam.
            const glm::dvec3 d = glm::normalize(n + glm::dvec3(0.013, 0.007, 0.011));
            const glm::dvec3 o = glm::dvec3(m.positions[v]) + 1e-4 * n;
            int crossings = 0;
            for (std::size_t t = 0; t < m.indices.size(); t += 3)
                crossings += hits(o, d, glm::dvec3(m.positions[m.indices[t]]), glm::dvec3(m.positions[m.indices[t + 1]]),
                                  glm::dvec3(m.positions[m.indices[t + 2]]));
            outward += crossings % 2 == 0;
            ++total;
        }
        EXPECT_GT(outward, total * 3 / 4) << "patch " << patch << ": " << outward << " of " << total;
    }
}

TEST(Teapot, TheKnobTopAndTheBottomCentreHaveAxisNormals) {
    const Mesh m = make_teapot(8);
    float top = -1e9f, bottom = 1e9f;
    for (const auto& p : m.positions) {
        top = std::max(top, p.y);
        bottom = std::min(bottom, p.y);
    }
    EXPECT_NEAR(top, 3.15f, 1e-5f);
    EXPECT_NEAR(bottom, 0.0f, 1e-5f);
    int at_top = 0, at_bottom = 0;
    for (std::size_t i = 0; i < m.positions.size(); ++i) {
        const auto& p = m.positions[i];
        if (std::hypot(p.x, p.z) > 1e-6f) continue;
        if (std::abs(p.y - 3.15f) < 1e-5f) {
            EXPECT_GT(m.normals[i].y, 0.999f);
            ++at_top;
        } else if (std::abs(p.y) < 1e-5f) {
            EXPECT_LT(m.normals[i].y, -0.999f);
            ++at_bottom;
        }
    }
    EXPECT_EQ(at_top, 4 * 9);     // the collapsed edge of each of the 4 knob patches
    EXPECT_EQ(at_bottom, 4 * 9);  // and of the 4 bottom patches
}

TEST(Teapot, NormalisedIntoTheUnitSphere) {
    Mesh m = make_teapot(8);
    normalise_to_unit_sphere(m);
    glm::vec3 lo(1e9f), hi(-1e9f);
    float r = 0;
    for (const auto& p : m.positions) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
        r = std::max(r, glm::length(p));
    }
    EXPECT_NEAR(r, 1.0f, 1e-5f);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(lo[k] + hi[k], 0.0f, 1e-5f);
    // Spout to +X, up +Y: the pot is wider in x (-3 .. 3.43) than it is tall (3.15) or deep (4).
    EXPECT_GT(hi.x - lo.x, hi.y - lo.y);
}

}  // namespace
}  // namespace glint::render
