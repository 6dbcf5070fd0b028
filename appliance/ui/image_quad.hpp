// An 8-bit RGB image drawn over the whole frame (the camera's picture behind the capture screens,
// the map's preview while processing): one texture, re-filled when the image changes.
#pragma once

#include <opencv2/core/mat.hpp>

#include "appliance/gl/gl_objects.hpp"
#include "appliance/gl/gl_program.hpp"

namespace glint::ui {

class ImageQuad {
public:
    ImageQuad();
    // CV_8UC3 in R, G, B order, rows top first.
    void upload(const cv::Mat& rgb);
    bool empty() const { return width_ == 0; }
    // Into the bound framebuffer (its viewport), stretched to fill it.
    void draw() const;
    GLuint texture() const { return texture_.id(); }

private:
    gl::GlProgram program_;
    gl::GlVertexArray vao_;
    gl::GlTexture texture_;
    int width_ = 0, height_ = 0;
};

}  // namespace glint::ui
