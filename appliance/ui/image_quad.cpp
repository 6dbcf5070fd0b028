#include "appliance/ui/image_quad.hpp"

#include "appliance/core/errors.hpp"
#include "appliance/gl/gl_context.hpp"

namespace glint::ui {

ImageQuad::ImageQuad()
    : program_("textured_quad.vert", "textured_quad.frag"), vao_(gl::GlVertexArray::create()), texture_(gl::GlTexture::create()) {}

void ImageQuad::upload(const cv::Mat& rgb) {
    if (rgb.type() != CV_8UC3 || rgb.empty()) throw RuntimeError("image quad: want a non-empty 8-bit RGB image");
    const cv::Mat packed = rgb.isContinuous() ? rgb : rgb.clone();
    glBindTexture(GL_TEXTURE_2D, texture_.id());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    if (packed.cols != width_ || packed.rows != height_) {
        glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, packed.cols, packed.rows, 0, GL_RGB, GL_UNSIGNED_BYTE, packed.data);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
        glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        width_ = packed.cols;
        height_ = packed.rows;
    } else {
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width_, height_, GL_RGB, GL_UNSIGNED_BYTE, packed.data);
    }
    gl::check_gl("uploading an image");
}

void ImageQuad::draw() const { draw_texture(texture_.id(), false); }

void ImageQuad::draw_texture(GLuint texture, bool rows_bottom_first) const {
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    program_.use();
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, texture);
    glUniform1i(program_.uniform("u_image"), 0);
    glUniform1i(program_.uniform("u_flip"), rows_bottom_first ? 1 : 0);
    glBindVertexArray(vao_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
    gl::check_gl("drawing an image");
}

ViewTarget::ViewTarget(int width, int height)
    : width_(width), height_(height), texture_(gl::GlTexture::create()), framebuffer_(gl::GlFramebuffer::create()) {
    glBindTexture(GL_TEXTURE_2D, texture_.id());
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, width, height, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
    glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, texture_.id(), 0);
    if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
        throw RuntimeError("the AR view's " + std::to_string(width) + "x" + std::to_string(height) + " frame is incomplete");
    gl::check_gl("creating the AR view's frame");
}

void ViewTarget::bind() const {
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
    glViewport(0, 0, width_, height_);
}

}  // namespace glint::ui
