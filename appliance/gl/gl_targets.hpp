// Float textures and multiple-render-target framebuffers: what the GPU convolution engine and
// the GPU capture accumulation draw into and read back.
#pragma once

#include <GLES3/gl3.h>

#include <cstddef>
#include <vector>

#include "appliance/core/hdr_image.hpp"
#include "appliance/gl/gl_objects.hpp"

namespace glint::gl {

// RGBA float rows read from GL (bottom row first) in image order (top row first), as images
// and EXR files keep them.
std::vector<float> rows_top_first(const std::vector<float>& bottom_up, int width, int height);

// An RGBA32F texture with nearest filtering and clamped edges (rgba may be null: undefined texels).
GlTexture make_float_texture(int width, int height, const float* rgba);
// The RGB of an image as an RGBA32F texture.
GlTexture upload_image(const HdrImage& image);

// The RGB of an image into an RGBA32F texture (as upload_image) a band of rows at a time, so
// that a frame pays for at most `max_bytes` of texels: a 1024x512 map at once cost a kiosk frame
// 44 ms on llvmpipe, half of it converting into a fresh 8 MB buffer (its pages faulted in), half
// in the driver's copy. The band's buffer is reused. The image must outlive the upload.
inline constexpr std::size_t kUploadBandBytes = std::size_t(1) << 20;  // upload_image's bands
class TextureUpload {
public:
    explicit TextureUpload(const HdrImage& image);  // allocates the texture (undefined texels)
    // Uploads the next rows, at least one, about max_bytes of RGBA32F. Returns done().
    bool step(std::size_t max_bytes);
    bool done() const { return next_row_ >= image_->height(); }
    // The texture, once done() (throws RuntimeError before).
    GlTexture take();

private:
    const HdrImage* image_;
    GlTexture texture_;
    int next_row_ = 0;
    std::vector<float> band_;
};

// A framebuffer drawing into `count` RGBA32F textures of one size (MRT). Throws RuntimeError when
// the driver cannot render to them (no GL_EXT_color_buffer_float).
class RenderTargets {
public:
    RenderTargets(int width, int height, int count);
    void bind() const;
    GLuint texture(int k) const { return textures_[std::size_t(k)].id(); }
    // Reads target k back, RGBA per texel, row 0 first.
    std::vector<float> read(int k) const;
    int width() const { return width_; }
    int height() const { return height_; }

private:
    int width_, height_;
    std::vector<GlTexture> textures_;
    GlFramebuffer framebuffer_;
};

}  // namespace glint::gl
