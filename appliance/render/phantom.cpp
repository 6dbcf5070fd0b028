#include "appliance/render/phantom.hpp"

#include <glm/gtc/type_ptr.hpp>

#include "appliance/core/errors.hpp"
#include "appliance/gl/gl_context.hpp"

namespace glint::render {

PhantomGeometry::PhantomGeometry() : program_("render_depth.vert", "render_depth.frag") {}

PhantomGeometry::Drawable PhantomGeometry::upload(const std::vector<glm::vec3>& positions,
                                                  const std::vector<std::uint32_t>& indices) {
    Drawable d;
    d.vao = gl::GlVertexArray::create();
    d.vertices = gl::GlBuffer::create();
    d.indices = gl::GlBuffer::create();
    glBindVertexArray(d.vao.id());
    glBindBuffer(GL_ARRAY_BUFFER, d.vertices.id());
    glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(positions.size() * sizeof(glm::vec3)), positions.data(), GL_STATIC_DRAW);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(glm::vec3), nullptr);
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, d.indices.id());
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(indices.size() * sizeof(std::uint32_t)), indices.data(),
                 GL_STATIC_DRAW);
    glBindVertexArray(0);
    d.count = GLsizei(indices.size());
    gl::check_gl("uploading phantom geometry");
    return d;
}

void PhantomGeometry::set_table(double height, double half_extent) {
    const float y = float(height), e = float(half_extent);
    table_ = upload({{-e, y, -e}, {e, y, -e}, {e, y, e}, {-e, y, e}}, {0, 1, 2, 0, 2, 3});
    table_height_ = height;
}

void PhantomGeometry::add_proxy(const Mesh& proxy) {
    if (proxy.indices.empty()) throw InputError("--proxy " + proxy.source + ": no triangles");
    proxies_.push_back(upload(proxy.positions, proxy.indices));
}

void PhantomGeometry::draw_depth(const glm::mat4& view_projection) const {
    if (empty()) return;
    GLboolean mask[4];
    glGetBooleanv(GL_COLOR_WRITEMASK, mask);
    GLint saved[kMarkedTargets];
    for (int k = 0; k < kMarkedTargets; ++k) glGetIntegerv(GLenum(GL_DRAW_BUFFER0 + k), &saved[k]);
    glDepthMask(GL_TRUE);
    program_.use();
    glUniformMatrix4fv(program_.uniform("u_view_projection"), 1, GL_FALSE, glm::value_ptr(view_projection));
    auto draw = [](const Drawable& d) {
        glBindVertexArray(d.vao.id());
        glDrawElements(GL_TRIANGLES, d.count, GL_UNSIGNED_INT, nullptr);
    };
    if (table_) {
        glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
        draw(*table_);
    }
    if (!proxies_.empty()) {
        // Only the second target (the renderer's normal target) takes the mark.
        const GLenum mark[2] = {GL_NONE, GLenum(saved[1])};
        glDrawBuffers(2, mark);
        glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
        for (const Drawable& d : proxies_) draw(d);
        GLenum restore[kMarkedTargets];
        for (int k = 0; k < kMarkedTargets; ++k) restore[k] = GLenum(saved[k]);
        glDrawBuffers(kMarkedTargets, restore);
    }
    glBindVertexArray(0);
    glColorMask(mask[0], mask[1], mask[2], mask[3]);
    gl::check_gl("drawing phantom geometry");
}

}  // namespace glint::render
