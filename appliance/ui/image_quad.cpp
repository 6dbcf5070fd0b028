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

void ImageQuad::draw() const {
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    program_.use();
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, texture_.id());
    glUniform1i(program_.uniform("u_image"), 0);
    glBindVertexArray(vao_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
    gl::check_gl("drawing an image");
}

}  // namespace glint::ui
