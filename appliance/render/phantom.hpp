// Phantom geometry (docs/render.md, "Table, phantom geometry and shadows"): stand-ins for real
// things, drawn into the depth buffer (and a proxy's mark, below) before the object, so that the real table and
// real objects hide the virtual one where they are in front of it. Nothing of them is drawn in
// colour: the camera image (or the environment) shows them.
//
// Coordinates are the renderer's world (docs/conventions.md: +Y up, -Z forward), in the units
// where the object is normalised into the unit sphere at the origin; proxy meshes are used as
// they are, not normalised.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <glm/glm.hpp>

#include "appliance/gl/gl_objects.hpp"
#include "appliance/gl/gl_program.hpp"
#include "appliance/render/mesh.hpp"

namespace glint::render {

class PhantomGeometry {
public:
    PhantomGeometry();
    // The table: the plane y = height, drawn as a square of half-side `half_extent` around the
    // origin (the camera's far plane is at 100).
    void set_table(double height, double half_extent = 100.0);
    std::optional<double> table_height() const { return table_height_; }
    void add_proxy(const Mesh& proxy);
    bool empty() const { return !table_ && proxies_.empty(); }
    // Into the bound framebuffer with its depth test (GL_LESS) and viewport set up: depth, and
    // for proxies the mark alpha = -1 in the second draw buffer (the renderer's normal target),
    // so the composite leaves the table's shadow off real things in front of the table. The
    // framebuffer's draw buffers (up to kMarkedTargets) are restored afterwards.
    static constexpr int kMarkedTargets = 4;
    void draw_depth(const glm::mat4& view_projection) const;

private:
    struct Drawable {
        gl::GlVertexArray vao;
        gl::GlBuffer vertices, indices;
        GLsizei count = 0;
    };
    static Drawable upload(const std::vector<glm::vec3>& positions, const std::vector<std::uint32_t>& indices);
    gl::GlProgram program_;
    std::optional<double> table_height_;
    std::optional<Drawable> table_;
    std::vector<Drawable> proxies_;
};

}  // namespace glint::render
