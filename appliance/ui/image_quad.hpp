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
    // Another texture (RGBA or RGB, rows bottom first as GL renders them) the same way.
    void draw_texture(GLuint texture, bool rows_bottom_first) const;
    GLuint texture() const { return texture_.id(); }

private:
    gl::GlProgram program_;
    gl::GlVertexArray vao_;
    gl::GlTexture texture_;
    int width_ = 0, height_ = 0;
};

// An 8-bit frame of its own size to draw into (the AR view at the camera's resolution, shown
// stretched over the display: the object gets the pixel footprint of the real scene around it,
// and llvmpipe shades a sixteenth of a 1280x720 frame's pixels).
class ViewTarget {
public:
    ViewTarget(int width, int height);
    void bind() const;  // as the draw framebuffer, viewport set to the whole of it
    GLuint texture() const { return texture_.id(); }
    int width() const { return width_; }
    int height() const { return height_; }

private:
    int width_, height_;
    gl::GlTexture texture_;
    gl::GlFramebuffer framebuffer_;
};

}  // namespace glint::ui
