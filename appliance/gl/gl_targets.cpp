#include "appliance/gl/gl_targets.hpp"

#include <algorithm>
#include <cstddef>

#include "appliance/core/errors.hpp"
#include "appliance/gl/gl_context.hpp"

namespace glint::gl {

std::vector<float> rows_top_first(const std::vector<float>& bottom_up, int width, int height) {
    std::vector<float> out(bottom_up.size());
    const std::size_t row = std::size_t(width) * 4;
    for (int y = 0; y < height; ++y)
        std::copy_n(bottom_up.begin() + std::ptrdiff_t(std::size_t(height - 1 - y) * row), row,
                    out.begin() + std::ptrdiff_t(std::size_t(y) * row));
    return out;
}

GlTexture make_float_texture(int width, int height, const float* rgba) {
    GlTexture t = GlTexture::create();
    glBindTexture(GL_TEXTURE_2D, t.id());
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, width, height, 0, GL_RGBA, GL_FLOAT, rgba);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    check_gl("creating an RGBA32F texture");
    return t;
}

GlTexture upload_image(const HdrImage& image) {
    TextureUpload upload(image);
    while (!upload.step(kUploadBandBytes)) {  // no image-sized conversion buffer
    }
    return upload.take();
}

TextureUpload::TextureUpload(const HdrImage& image)
    : image_(&image), texture_(make_float_texture(image.width(), image.height(), nullptr)) {}

bool TextureUpload::step(std::size_t max_bytes) {
    if (done()) return true;
    const int width = image_->width();
    const std::size_t row_bytes = std::size_t(width) * 4 * sizeof(float);
    const int rows = std::clamp(int(max_bytes / row_bytes), 1, image_->height() - next_row_);
    band_.resize(std::size_t(rows) * std::size_t(width) * 4);
    for (int j = 0; j < rows; ++j) {
        const float* src = image_->row(next_row_ + j);
        float* dst = band_.data() + std::size_t(j) * std::size_t(width) * 4;
        for (int i = 0; i < width; ++i) {
            dst[4 * i] = src[3 * i];
            dst[4 * i + 1] = src[3 * i + 1];
            dst[4 * i + 2] = src[3 * i + 2];
            dst[4 * i + 3] = 1.0f;
        }
    }
    glBindTexture(GL_TEXTURE_2D, texture_.id());
    glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
    glTexSubImage2D(GL_TEXTURE_2D, 0, 0, next_row_, width, rows, GL_RGBA, GL_FLOAT, band_.data());
    check_gl("uploading rows of an RGBA32F texture");
    next_row_ += rows;
    if (done()) band_ = std::vector<float>();  // the band's memory back once the texture is whole
    return done();
}

GlTexture TextureUpload::take() {
    if (!done()) throw RuntimeError("texture upload: taken before its last rows");
    return std::move(texture_);
}

RenderTargets::RenderTargets(int width, int height, int count)
    : width_(width), height_(height), framebuffer_(GlFramebuffer::create()) {
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
    std::vector<GLenum> buffers;
    for (int k = 0; k < count; ++k) {
        textures_.push_back(make_float_texture(width, height, nullptr));
        glFramebufferTexture2D(GL_FRAMEBUFFER, GLenum(GL_COLOR_ATTACHMENT0 + k), GL_TEXTURE_2D,
                               textures_.back().id(), 0);
        buffers.push_back(GLenum(GL_COLOR_ATTACHMENT0 + k));
    }
    glDrawBuffers(GLsizei(buffers.size()), buffers.data());
    const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE)
        throw RuntimeError("render targets: " + std::to_string(count) + " RGBA32F render targets of " +
                           std::to_string(width) + "x" + std::to_string(height) + " are not complete (status 0x" +
                           std::to_string(status) + ")");
    check_gl("creating render targets");
}

void RenderTargets::bind() const {
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_.id());
    glViewport(0, 0, width_, height_);
}

std::vector<float> RenderTargets::read(int k) const {
    glBindFramebuffer(GL_READ_FRAMEBUFFER, framebuffer_.id());
    glReadBuffer(GLenum(GL_COLOR_ATTACHMENT0 + k));
    std::vector<float> rgba(std::size_t(width_) * std::size_t(height_) * 4);
    glReadPixels(0, 0, width_, height_, GL_RGBA, GL_FLOAT, rgba.data());
    check_gl("reading a render target back");
    return rgba;
}

}  // namespace glint::gl
