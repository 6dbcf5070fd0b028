#include "appliance/render/renderer.hpp"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>

#include <algorithm>
#include <limits>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>

#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/gl/gl_context.hpp"
#include "appliance/gl/gl_targets.hpp"

namespace glint::render {
namespace {

constexpr int kTargets = 4;  // radiance, normal, reflect, HDR frame
enum Target { kRadiance = 0, kNormal = 1, kReflect = 2, kHdr = 3 };

double luminance(const float* rgb) { return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]; }

gl::GlTexture upload_map(const HdrImage& image, const char* what) {
    if (image.empty()) throw RuntimeError(std::string("renderer: the ") + what + " map is empty");
    return gl::upload_image(image);
}

glm::dmat4 view_matrix(const Camera& c) { return glm::lookAt(c.eye, c.target, c.up); }

glm::dmat4 projection_matrix(const Camera& c, int width, int height) {
    return glm::perspective(glm::radians(c.fov_y_deg), double(width) / double(height), c.near, c.far);
}

// RGBA rows top first: the frame's 4-float image as an RGB HdrImage (alpha dropped).
HdrImage rgb_of(const std::vector<float>& rgba, int width, int height) {
    HdrImage out(width, height);
    for (std::size_t k = 0; k < out.texel_count(); ++k)
        for (int c = 0; c < 3; ++c) out.data()[3 * k + std::size_t(c)] = rgba[4 * k + std::size_t(c)];
    return out;
}

void save_rgba_exr(const std::filesystem::path& path, const std::vector<float>& rgba, int width, int height) {
    write_file_atomically(path, [&](const std::filesystem::path& tmp) {
        try {
            Imf::Header header(width, height);
            header.compression() = Imf::ZIP_COMPRESSION;
            for (const char* name : {"R", "G", "B", "A"}) header.channels().insert(name, Imf::Channel(Imf::FLOAT));
            Imf::OutputFile file(tmp.c_str(), header);
            Imf::FrameBuffer fb;
            char* base = const_cast<char*>(reinterpret_cast<const char*>(rgba.data()));
            const std::size_t xs = 4 * sizeof(float);
            const std::size_t ys = xs * std::size_t(width);
            const char* names[4] = {"R", "G", "B", "A"};
            for (int c = 0; c < 4; ++c) fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
            file.setFrameBuffer(fb);
            file.writePixels(height);
        } catch (const std::exception& e) {
            throw RuntimeError("cannot write " + path.string() + ": " + e.what());
        }
    });
}

}  // namespace

ToneMap meter_reinhard(const std::vector<float>& rgba, double key, double delta) {
    ToneMap t;
    t.key = key;
    t.delta = delta;
    double sum_log = 0, max_l = 0;
    long long count = 0;
    for (std::size_t k = 0; k + 3 < rgba.size(); k += 4) {
        if (!(rgba[k + 3] > 0)) continue;
        const double l = std::max(0.0, luminance(&rgba[k]));
        sum_log += std::log(delta + l);
        max_l = std::max(max_l, l);
        ++count;
    }
    t.pixels = count;
    if (count == 0) {
        t.log_average = key;
        t.white = 1.0;
        return t;
    }
    t.log_average = std::exp(sum_log / double(count));
    t.white = std::max(1e-6, t.scale() * max_l);
    return t;
}

void save_aovs(const std::filesystem::path& dir, const Aovs& aovs) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) throw RuntimeError("--aov " + dir.string() + ": cannot create the directory: " + ec.message());
    save_rgba_exr(dir / "radiance.exr", aovs.radiance, aovs.width, aovs.height);
    save_exr(dir / "normal.exr", rgb_of(aovs.normal, aovs.width, aovs.height));
    save_exr(dir / "reflect.exr", rgb_of(aovs.reflect, aovs.width, aovs.height));
    if (!aovs.shadow.empty()) save_exr(dir / "shadow.exr", rgb_of(aovs.shadow, aovs.width, aovs.height));
}

Renderer::Renderer(const Mesh& mesh, const Material& material, const ShadingMaps& maps, int width, int height,
                   const Camera& camera, int msaa, FrameTargets targets)
    : Renderer(mesh, std::vector<Material>(std::max<std::size_t>(1, mesh.parts.size()), material), maps, width, height,
               camera, msaa, targets) {}

namespace {

// Whether the driver multisamples `format` renderbuffers `samples` times.
bool multisamples(GLenum format, int samples) {
    GLint most = 0;
    glGetInternalformativ(GL_RENDERBUFFER, format, GL_SAMPLES, 1, &most);  // the largest count
    return most >= samples;
}

}  // namespace

Renderer::Renderer(const Mesh& mesh, const std::vector<Material>& part_materials, const ShadingMaps& maps, int width,
                   int height, const Camera& camera, int msaa, FrameTargets targets)
    : width_(width), height_(height), camera_(camera), msaa_(msaa) {
    if (width < 1 || height < 1) throw InputError("renderer: frame size must be positive");
    if (msaa != 1 && msaa != 4) throw InputError("--msaa: want 1 or 4, got " + std::to_string(msaa));
    if (mesh.indices.empty()) throw InputError("renderer: the mesh " + mesh.source + " has no triangles");
    const std::size_t parts = std::max<std::size_t>(1, mesh.parts.size());
    if (part_materials.size() != parts)
        throw RuntimeError("renderer: " + std::to_string(part_materials.size()) + " materials for the " +
                           std::to_string(parts) + " parts of " + mesh.source);

    // The triangles grouped by distinct material (parts of one material need not be adjacent in
    // the file), so that each material is one draw of one index range.
    std::vector<std::uint32_t> grouped;
    grouped.reserve(mesh.indices.size());
    for (std::size_t p = 0; p < parts; ++p) {
        const Material& m = part_materials[p];
        auto it = std::find_if(draws_.begin(), draws_.end(), [&](const Draw& d) { return same_shading(d.material, m); });
        if (it != draws_.end()) continue;  // gathered with the first part of this material
        Draw d;
        d.material = m;
        d.first_index = grouped.size();
        for (std::size_t q = p; q < parts; ++q) {
            if (!same_shading(part_materials[q], m)) continue;
            const std::size_t first = mesh.parts.empty() ? 0 : mesh.parts[q].first_index;
            const std::size_t count = mesh.parts.empty() ? mesh.indices.size() : mesh.parts[q].index_count;
            if (first + count > mesh.indices.size())
                throw InputError("renderer: a part of " + mesh.source + " runs past its indices");
            grouped.insert(grouped.end(), mesh.indices.begin() + std::ptrdiff_t(first),
                           mesh.indices.begin() + std::ptrdiff_t(first + count));
        }
        d.index_count = grouped.size() - d.first_index;
        if (m.diffuse() && !maps.irradiance) throw RuntimeError("renderer: the material " + m.spec + " needs the irradiance map");
        if (m.specular()) {
            const ReflectionMap* r = maps.reflection_for(m);
            if (!r) throw RuntimeError("renderer: the material " + m.spec + " needs the " + reflection_request(m).label + " map");
            d.reflection = int(r - maps.reflections.data());  // its texture: upload_maps below
        }
        draws_.push_back(std::move(d));
    }
    maps_ = std::make_shared<const ShadingMaps>(maps);
    index_total_ = grouped.size();

    scene_program_ = gl::GlProgram("render_scene.vert", "render_scene.frag");
    background_program_ = gl::GlProgram("fullscreen.vert", "render_background.frag");

    // The mesh: interleaved position and normal, 32-bit indices.
    std::vector<float> interleaved;
    interleaved.reserve(mesh.positions.size() * 6);
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
        const glm::vec3 p = mesh.positions[i], n = mesh.normals[i];
        interleaved.insert(interleaved.end(), {p.x, p.y, p.z, n.x, n.y, n.z});
    }
    vao_ = gl::GlVertexArray::create();
    vertices_ = gl::GlBuffer::create();
    indices_ = gl::GlBuffer::create();
    glBindVertexArray(vao_.id());
    glBindBuffer(GL_ARRAY_BUFFER, vertices_.id());
    glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(interleaved.size() * sizeof(float)), interleaved.data(), GL_STATIC_DRAW);
    glEnableVertexAttribArray(0);
    glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), nullptr);
    glEnableVertexAttribArray(1);
    glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float), reinterpret_cast<const void*>(3 * sizeof(float)));
    // Baked ambient occlusion, attribute 2, in its own buffer; a mesh without it reads the
    // attribute's constant value, set to 1 in draw() (so does --no-ao).
    if (!mesh.ao.empty()) {
        if (mesh.ao.size() != mesh.positions.size())
            throw InputError("renderer: the mesh " + mesh.source + " has " + std::to_string(mesh.ao.size()) +
                             " ao values for " + std::to_string(mesh.positions.size()) + " vertices");
        ao_values_ = gl::GlBuffer::create();
        glBindBuffer(GL_ARRAY_BUFFER, ao_values_.id());
        glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(mesh.ao.size() * sizeof(float)), mesh.ao.data(), GL_STATIC_DRAW);
        glVertexAttribPointer(2, 1, GL_FLOAT, GL_FALSE, sizeof(float), nullptr);
        has_ao_ = true;
    }
    glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, indices_.id());
    glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(grouped.size() * sizeof(std::uint32_t)), grouped.data(),
                 GL_STATIC_DRAW);
    glBindVertexArray(0);
    empty_vao_ = gl::GlVertexArray::create();

    upload_maps(/*later=*/false);

    // The frames' format: a multisampled frame resolves by blit into the single-sampled targets,
    // and ES 3 blits from a multisampled buffer only into the identical format, so both are one.
    if (targets == FrameTargets::Float && msaa_ > 1 && !multisamples(GL_RGBA32F, msaa_))
        throw RuntimeError("renderer: the GL driver cannot multisample RGBA32F " + std::to_string(msaa_) +
                           "x; use half-float frame targets or --msaa 1");
    half_ = targets == FrameTargets::Half ||
            (targets == FrameTargets::Auto && msaa_ > 1 && !multisamples(GL_RGBA32F, msaa_));
    // The float targets and a depth buffer (the object may hide parts of itself).
    make_targets(half_, targets_, depth_, framebuffer_);
    if (msaa_ > 1) create_multisampled_targets();
    gl::check_gl("creating the renderer");
}

void Renderer::make_targets(bool half, gl::GlTexture (&textures)[4], gl::GlName<RenderbufferTraits>& depth,
                            gl::GlFramebuffer& framebuffer) {
    framebuffer = gl::GlFramebuffer::create();
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer.id());
    GLenum buffers[kTargets];
    for (int k = 0; k < kTargets; ++k) {
        if (half) {
            textures[k] = gl::GlTexture::create();
            glBindTexture(GL_TEXTURE_2D, textures[k].id());
            glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA16F, width_, height_, 0, GL_RGBA, GL_HALF_FLOAT, nullptr);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
            glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
        } else {
            textures[k] = gl::make_float_texture(width_, height_, nullptr);
        }
        glFramebufferTexture2D(GL_FRAMEBUFFER, GLenum(GL_COLOR_ATTACHMENT0 + k), GL_TEXTURE_2D, textures[k].id(), 0);
        buffers[k] = GLenum(GL_COLOR_ATTACHMENT0 + k);
    }
    depth = gl::GlName<RenderbufferTraits>::create();
    glBindRenderbuffer(GL_RENDERBUFFER, depth.id());
    glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, width_, height_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth.id());
    glDrawBuffers(kTargets, buffers);
    const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE)
        throw RuntimeError("renderer: " + std::to_string(kTargets) + " " + (half ? "RGBA16F" : "RGBA32F") + " targets of " +
                           std::to_string(width_) + "x" + std::to_string(height_) + " with depth are not complete (status " +
                           std::to_string(status) + "; needs GL_EXT_color_buffer_float)");
}

// The frame's four targets again, multisampled, in the frames' format (RGBA32F, or RGBA16F where
// the driver cannot multisample RGBA32F or half was asked for: half floats hold the radiance to
// 1e-3 relative, and the AOVs never come from these, read_aovs draws them single-sampled).
void Renderer::create_multisampled_targets() {
    GLint max_samples = 0;
    glGetIntegerv(GL_MAX_SAMPLES, &max_samples);
    const GLenum format = half_ ? GLenum(GL_RGBA16F) : GLenum(GL_RGBA32F);
    if (!multisamples(format, msaa_))
        throw RuntimeError("--msaa " + std::to_string(msaa_) + ": the GL driver cannot multisample " + frame_format() + " " +
                           std::to_string(msaa_) + "x (GL_MAX_SAMPLES " + std::to_string(max_samples) + "); use --msaa 1");
    ms_framebuffer_ = gl::GlFramebuffer::create();
    glBindFramebuffer(GL_FRAMEBUFFER, ms_framebuffer_.id());
    GLenum buffers[kTargets];
    for (int k = 0; k < kTargets; ++k) {
        ms_colour_[k] = gl::GlName<RenderbufferTraits>::create();
        glBindRenderbuffer(GL_RENDERBUFFER, ms_colour_[k].id());
        glRenderbufferStorageMultisample(GL_RENDERBUFFER, msaa_, format, width_, height_);
        glFramebufferRenderbuffer(GL_FRAMEBUFFER, GLenum(GL_COLOR_ATTACHMENT0 + k), GL_RENDERBUFFER, ms_colour_[k].id());
        buffers[k] = GLenum(GL_COLOR_ATTACHMENT0 + k);
    }
    ms_depth_ = gl::GlName<RenderbufferTraits>::create();
    glBindRenderbuffer(GL_RENDERBUFFER, ms_depth_.id());
    glRenderbufferStorageMultisample(GL_RENDERBUFFER, msaa_, GL_DEPTH_COMPONENT24, width_, height_);
    glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, ms_depth_.id());
    glDrawBuffers(kTargets, buffers);
    const GLenum status = glCheckFramebufferStatus(GL_FRAMEBUFFER);
    if (status != GL_FRAMEBUFFER_COMPLETE)
        throw RuntimeError("--msaa " + std::to_string(msaa_) + ": the multisampled float targets are not complete (status " +
                           std::to_string(status) + "); use --msaa 1");
    gl::check_gl("creating the multisampled targets");
}

// Blits (resolves: the mean of the samples) the targets the composite and the meter read: the
// radiance, the normal (its alpha carries a proxy's mark) and, when metering, the HDR frame.
void Renderer::resolve(bool with_hdr) const {
    glBindFramebuffer(GL_READ_FRAMEBUFFER, ms_framebuffer_.id());
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, framebuffer_.id());
    for (const int k : {int(kRadiance), int(kNormal), int(kHdr)}) {
        if (k == kHdr && !with_hdr) continue;
        GLenum draw[kTargets] = {GL_NONE, GL_NONE, GL_NONE, GL_NONE};
        draw[k] = GLenum(GL_COLOR_ATTACHMENT0 + k);
        glReadBuffer(GLenum(GL_COLOR_ATTACHMENT0 + k));
        glDrawBuffers(kTargets, draw);
        glBlitFramebuffer(0, 0, width_, height_, 0, 0, width_, height_, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    gl::check_gl("resolving the multisampled targets");
}

namespace {

// The background needs no more than about 4096 columns (a 1280-pixel frame spans 67 degrees:
// 6900 pixels a turn at most, and the lookup is bilinear); an 8192x4096 map would be 512 MiB as
// RGBA32F. Halved by 2x2 means, which keep every light's power.
HdrImage background_level(const HdrImage& environment) {
    constexpr int kMaxColumns = 4096;
    HdrImage level = environment;
    while (level.width() > kMaxColumns && level.width() % 2 == 0 && level.height() % 2 == 0) {
        HdrImage half(level.width() / 2, level.height() / 2);
        for (int j = 0; j < half.height(); ++j)
            for (int i = 0; i < half.width(); ++i)
                for (int c = 0; c < 3; ++c)
                    half.row(j)[3 * i + c] = 0.25f * (level.row(2 * j)[6 * i + c] + level.row(2 * j)[6 * i + 3 + c] +
                                                      level.row(2 * j + 1)[6 * i + c] + level.row(2 * j + 1)[6 * i + 3 + c]);
        level = std::move(half);
    }
    return level;
}

}  // namespace

void Renderer::set_background_environment(const HdrImage& environment) {
    environment_ = upload_map(environment.width() > 4096 ? background_level(environment) : environment, "environment");
    background_ = Background::Environment;
}

void Renderer::set_background_image(const gl::RgbImage& image) {
    if (image.width < 1 || image.height < 1) throw InputError("--background: the image is empty");
    if (image.pixels.size() != std::size_t(image.width) * std::size_t(image.height) * 3)
        throw InputError("--background: the image's pixels do not match its size");
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    // The kiosk sends every camera picture: the same texture is refilled while the size holds (a
    // new one a frame made the driver allocate and free a few hundred kB a frame, which
    // fragments a heap that must stay flat for weeks).
    if (image_.id() != 0 && image_width_ == image.width && image_height_ == image.height) {
        glBindTexture(GL_TEXTURE_2D, image_.id());
        glTexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, image.width, image.height, GL_RGB, GL_UNSIGNED_BYTE, image.pixels.data());
        gl::check_gl("uploading the background image");
        background_ = Background::Image;
        return;
    }
    image_ = gl::GlTexture::create();
    image_width_ = image.width;
    image_height_ = image.height;
    glBindTexture(GL_TEXTURE_2D, image_.id());
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB8, image.width, image.height, 0, GL_RGB, GL_UNSIGNED_BYTE,
                 image.pixels.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    gl::check_gl("uploading the background image");
    background_ = Background::Image;
}

void Renderer::set_background_black() { background_ = Background::Black; }

void Renderer::set_camera_response(const CameraResponse& response, const CameraExposure& exposure) {
    if (!(exposure.exposure_ms > 0)) throw InputError("--exposure-ms: must be positive");
    if (!(exposure.gain > 0)) throw InputError("--gain: must be positive");
    exposure_ = exposure;
    // A frame's new exposure and gain are uniforms; the curve's table is uploaded when it changes.
    if (response_curve_ && response_curve_->inverse == response.inverse && response_curve_->gamma == response.gamma &&
        response_curve_->shoulder == response.shoulder && response_curve_->sensitivity == response.sensitivity)
        return;
    response_curve_ = response;
    std::vector<float> table(response.inverse.begin(), response.inverse.end());
    response_ = gl::GlTexture::create();
    glBindTexture(GL_TEXTURE_2D, response_.id());
    glTexImage2D(GL_TEXTURE_2D, 0, GL_R32F, 256, 1, 0, GL_RED, GL_FLOAT, table.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl::check_gl("uploading the camera response");
}

void Renderer::draw_scene() { draw(false, msaa_ > 1); }

void Renderer::draw(bool with_hdr, bool multisampled, bool with_reflect, bool aov) {
    if (aov && half_ && aov_framebuffer_.id() == 0) make_targets(false, aov_targets_, aov_depth_, aov_framebuffer_);
    const bool into_aovs = aov && half_;
    glBindFramebuffer(GL_FRAMEBUFFER, multisampled ? ms_framebuffer_.id()
                                      : into_aovs  ? aov_framebuffer_.id()
                                                   : framebuffer_.id());
    // Half-float targets hold at most 65504; a mirror's sun would overflow to infinity, and one
    // infinite sample makes its resolved pixel (and the meter's log-average) NaN.
    const float radiance_cap = half_ && !into_aovs ? 65504.0f : std::numeric_limits<float>::max();
    // Frames write the radiance and the normal (its alpha: a proxy's mark), which the composite
    // reads; the reflection direction only for the AOVs, the HDR frame only for the meter: a float
    // target less to write each frame (with 4x MSAA, 4 samples of 16 bytes a pixel).
    const GLenum buffers[kTargets] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1,
                                      with_reflect ? GLenum(GL_COLOR_ATTACHMENT2) : GLenum(GL_NONE),
                                      with_hdr ? GLenum(GL_COLOR_ATTACHMENT3) : GLenum(GL_NONE)};
    glDrawBuffers(kTargets, buffers);
    glViewport(0, 0, width_, height_);
    glDisable(GL_BLEND);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_CULL_FACE);
    glDepthMask(GL_TRUE);
    glClearColor(0, 0, 0, 0);
    glClearDepthf(1.0f);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);

    const glm::dmat4 view = view_matrix(camera_);

    if (with_hdr && background_ == Background::Environment) {
        glDisable(GL_DEPTH_TEST);
        glDepthMask(GL_FALSE);
        background_program_.use();
        set_camera_ray_uniforms(background_program_);
        glActiveTexture(GL_TEXTURE0);
        glBindTexture(GL_TEXTURE_2D, environment_.id());
        glUniform1i(background_program_.uniform("u_environment"), 0);
        glUniform1f(background_program_.uniform("u_radiance_cap"), radiance_cap);
        bind_shadow(background_program_, 1);
        glBindVertexArray(empty_vao_.id());
        glDrawArrays(GL_TRIANGLES, 0, 3);
        glDepthMask(GL_TRUE);
    }

    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LESS);
    if (phantoms_) phantoms_->draw_depth(glm::mat4(projection_matrix(camera_, width_, height_) * view));
    scene_program_.use();
    const glm::mat4 model(1.0f);
    const glm::mat3 normal_matrix = glm::transpose(glm::inverse(glm::mat3(model)));
    const glm::mat4 view_projection(projection_matrix(camera_, width_, height_) * view);
    glUniformMatrix4fv(scene_program_.uniform("u_model"), 1, GL_FALSE, glm::value_ptr(model));
    glUniformMatrix3fv(scene_program_.uniform("u_normal_matrix"), 1, GL_FALSE, glm::value_ptr(normal_matrix));
    glUniformMatrix4fv(scene_program_.uniform("u_view_projection"), 1, GL_FALSE, glm::value_ptr(view_projection));
    glUniform3f(scene_program_.uniform("u_eye"), float(camera_.eye.x), float(camera_.eye.y), float(camera_.eye.z));
    glUniform1f(scene_program_.uniform("u_radiance_cap"), radiance_cap);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, irradiance_.id());
    glUniform1i(scene_program_.uniform("u_irradiance"), 0);
    glUniform1i(scene_program_.uniform("u_reflection"), 1);
    glBindVertexArray(vao_.id());
    if (ao_ && has_ao_) {
        glEnableVertexAttribArray(2);
    } else {
        glDisableVertexAttribArray(2);
        glVertexAttrib1f(2, 1.0f);  // ao = 1: no baked occlusion, or --no-ao
    }
    for (const Draw& d : draws_) {
        const Material& m = d.material;
        glUniform3f(scene_program_.uniform("u_kd"), float(m.kd.x), float(m.kd.y), float(m.kd.z));
        glUniform3f(scene_program_.uniform("u_ks"), float(m.ks.x), float(m.ks.y), float(m.ks.z));
        glUniform1i(scene_program_.uniform("u_diffuse"), m.diffuse() ? 1 : 0);
        glUniform1i(scene_program_.uniform("u_specular"), m.specular() ? 1 : 0);
        const bool lobe = d.reflection >= 0 && maps_->reflections[std::size_t(d.reflection)].lookup == MapLookup::Lobe;
        glUniform1f(scene_program_.uniform("u_reflection_lobe"), lobe ? float(m.n) : 0.0f);
        // A map with fine tiles: read through them (tiled_map.hpp, render_lookup.glsl equirect_tiled;
        // factor 0 without).
        const TiledMapLayout tiles =
            d.reflection >= 0 ? maps_->reflections[std::size_t(d.reflection)].tiles : TiledMapLayout{};
        glUniform4i(scene_program_.uniform("u_reflection_tiles"), tiles.factor, tiles.tile, tiles.base_rows, tiles.per_row);
        glUniform2i(scene_program_.uniform("u_reflection_tile_rows"), tiles.slot_row, tiles.atlas_row);
        glActiveTexture(GL_TEXTURE1);
        glBindTexture(GL_TEXTURE_2D, d.reflection >= 0 ? reflection_textures_[std::size_t(d.reflection)].id() : 0);
        glDrawElements(GL_TRIANGLES, GLsizei(d.index_count), GL_UNSIGNED_INT,
                       reinterpret_cast<const void*>(d.first_index * sizeof(std::uint32_t)));
    }
    glBindVertexArray(0);
    glActiveTexture(GL_TEXTURE0);
    glDisable(GL_DEPTH_TEST);
    gl::check_gl("drawing the scene");
    if (multisampled) resolve(with_hdr);
}

std::vector<float> Renderer::read_target(int k, bool aov) const {
    glBindFramebuffer(GL_READ_FRAMEBUFFER, aov && half_ ? aov_framebuffer_.id() : framebuffer_.id());
    glReadBuffer(GLenum(GL_COLOR_ATTACHMENT0 + k));
    std::vector<float> bottom_up(std::size_t(width_) * std::size_t(height_) * 4);
    glReadPixels(0, 0, width_, height_, GL_RGBA, GL_FLOAT, bottom_up.data());
    gl::check_gl("reading a render target back");
    return gl::rows_top_first(bottom_up, width_, height_);
}

void Renderer::set_camera_ray_uniforms(const gl::GlProgram& program) const {
    const glm::mat3 world_from_camera(glm::transpose(glm::dmat3(view_matrix(camera_))));  // the view's rotation inverted
    const double ty = std::tan(glm::radians(camera_.fov_y_deg) / 2);
    glUniform2f(program.uniform("u_size"), float(width_), float(height_));
    glUniform2f(program.uniform("u_tan_half_fov"), float(ty * width_ / height_), float(ty));
    glUniformMatrix3fv(program.uniform("u_world_from_camera"), 1, GL_FALSE, glm::value_ptr(world_from_camera));
}

void Renderer::set_camera_match(const CameraMatch& match) {
    if (match.noise) {
        if (!response_curve_)
            throw InputError("camera noise: needs the camera's response (--camera CAL.json): the noise is in its exposure units");
        if (!response_curve_->has_noise())
            throw InputError("camera noise: " + response_curve_->source +
                             " has no \"noise\" (full_well_electrons, read_noise); add the sensor's from its datasheet");
    }
    if (!(std::isfinite(match.blur_px.x) && std::isfinite(match.blur_px.y) && glm::length(match.blur_px) <= 256.0))
        throw InputError("motion blur: the object's motion during the exposure must be finite and at most 256 pixels");
    match_ = match;
}

const ToneMap& Renderer::meter(double key) {
    draw(true, msaa_ > 1);
    tone_ = meter_reinhard(read_target(kHdr), key);
    return tone_;
}

const gl::GlProgram& Renderer::composite_program() const {
    const int background = background_ == Background::Image ? 1 : background_ == Background::Environment ? 2 : 0;
    const int camera = !response_curve_ ? 0 : response_curve_->parametric() ? 1 : 2;
    // 2: the baked grid holds the whole shadow, and the spheres' model beyond it is compiled out.
    const int shadow = !shadow_ ? 0 : shadow_->bake_holds_all() ? 2 : 1;
    const int noise = match_.noise && camera != 0 ? 1 : 0;
    const int blur = glm::length(match_.blur_px) >= 0.5 ? 1 : 0;  // under half a pixel: nothing to see
    const int key = blur * 2000 + noise * 1000 + background * 100 + camera * 10 + shadow;
    auto it = composite_programs_.find(key);
    if (it == composite_programs_.end())
        it = composite_programs_
                 .emplace(key, gl::GlProgram("fullscreen.vert", "render_composite.frag",
                                             {"BACKGROUND " + std::to_string(background),
                                              "CAMERA " + std::to_string(camera), "SHADOW " + std::to_string(shadow),
                                              "NOISE " + std::to_string(noise), "BLUR " + std::to_string(blur)}))
                 .first;
    return it->second;
}

void Renderer::composite() const {
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    const gl::GlProgram& program = composite_program();
    program.use();
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, targets_[kRadiance].id());
    glUniform1i(program.uniform("u_radiance"), 0);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, image_.id());
    glUniform1i(program.uniform("u_image"), 1);
    glActiveTexture(GL_TEXTURE2);
    glBindTexture(GL_TEXTURE_2D, environment_.id());
    glUniform1i(program.uniform("u_environment"), 2);
    bind_shadow(program, 3);
    glActiveTexture(GL_TEXTURE4);
    glBindTexture(GL_TEXTURE_2D, targets_[kNormal].id());
    glUniform1i(program.uniform("u_normal"), 4);  // a proxy's mark (phantom.hpp)
    set_camera_ray_uniforms(program);
    glActiveTexture(GL_TEXTURE5);
    glBindTexture(GL_TEXTURE_2D, response_.id());
    glUniform1i(program.uniform("u_response"), 5);
    if (response_curve_) {
        glUniform1f(program.uniform("u_camera_scale"), float(exposure_.scale(*response_curve_)));
        glUniform1f(program.uniform("u_gamma"), response_curve_->parametric() ? float(response_curve_->gamma) : 0.0f);
        glUniform1f(program.uniform("u_shoulder"), float(response_curve_->shoulder));
    }
    if (match_.noise && response_curve_) {
        // Variance of X: X gain / full well + read^2 (camera_response.hpp).
        glUniform2f(program.uniform("u_noise"), float(exposure_.gain / response_curve_->full_well_electrons),
                    float(response_curve_->read_noise * response_curve_->read_noise));
        glUniform1ui(program.uniform("u_seed"), match_.frame);
    }
    if (glm::length(match_.blur_px) >= 0.5) {
        glUniform2f(program.uniform("u_blur"), float(match_.blur_px.x), float(match_.blur_px.y));
        // A tap per pixel of the path (and one more), at most 64: a longer smear is sampled sparser.
        glUniform1i(program.uniform("u_blur_taps"), std::min(64, int(std::ceil(glm::length(match_.blur_px))) + 1));
    }
    glUniform1f(program.uniform("u_scale"), float(tone_.scale()));
    glUniform1f(program.uniform("u_white_sq"), float(tone_.white * tone_.white));
    glBindVertexArray(empty_vao_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glBindVertexArray(0);
    glActiveTexture(GL_TEXTURE0);
    gl::check_gl("compositing the frame");
}

void Renderer::replace_maps(const ShadingMaps& maps) { replace_maps(std::make_shared<const ShadingMaps>(maps)); }

void Renderer::replace_maps(std::shared_ptr<const ShadingMaps> shared) {
    if (!shared) throw RuntimeError("renderer: no maps given");
    const ShadingMaps& maps = *shared;
    for (const Draw& d : draws_) {
        if (d.material.diffuse() && !maps.irradiance)
            throw RuntimeError("renderer: the new maps have no irradiance map for " + d.material.spec);
        if (d.material.specular() && !maps.reflection_for(d.material))
            throw RuntimeError("renderer: the new maps have no " + reflection_request(d.material).label + " map");
    }
    for (Draw& d : draws_)
        if (d.material.specular()) d.reflection = int(maps.reflection_for(d.material) - maps.reflections.data());
    maps_ = std::move(shared);
    upload_maps(/*later=*/true);
    gl::check_gl("replacing the maps");
}

// Every map given gets a texture, not only those the current draws use: the kiosk's button
// switches materials (set_uniform_material) between frames, and an upload then (8 MB for a
// mirror's map of 1024x512) cost the visitor's frame 20-40 ms. The maps the draws use are uploaded
// now; with `later`, the others wait for upload_pending_map (a band of rows a call, from frames
// with time to spare: all at once cost the frame the final maps arrived in 34 ms, and one whole
// 1024x512 map a frame 44 ms).
void Renderer::upload_maps(bool later) {
    const ShadingMaps& maps = *maps_;
    uploading_.reset();
    const auto drawn = [&](int k) {  // k: a reflection's index, -1 the irradiance
        return std::any_of(draws_.begin(), draws_.end(),
                           [&](const Draw& d) { return k < 0 ? d.material.diffuse() : d.reflection == k; });
    };
    pending_maps_.clear();
    irradiance_ = gl::GlTexture{};
    if (maps.irradiance) {
        if (!later || drawn(-1)) irradiance_ = upload_map(*maps.irradiance, "irradiance");
        else pending_maps_.push_back(-1);
    }
    reflection_textures_.clear();
    reflection_textures_.resize(maps.reflections.size());
    for (std::size_t k = 0; k < maps.reflections.size(); ++k) {
        if (!later || drawn(int(k))) reflection_textures_[k] = upload_map(map_image(int(k)), "reflection");
        else pending_maps_.push_back(int(k));
    }
}

const HdrImage& Renderer::map_image(int k) const {
    if (k < 0) return *maps_->irradiance;
    const ReflectionMap& r = maps_->reflections[std::size_t(k)];
    return r.texture.empty() ? r.image : r.texture;  // with fine tiles, packed below the image
}

void Renderer::finish_upload(int k, gl::GlTexture texture) {
    pending_maps_.erase(std::find(pending_maps_.begin(), pending_maps_.end(), k));
    if (k < 0) irradiance_ = std::move(texture);
    else reflection_textures_[std::size_t(k)] = std::move(texture);
}

void Renderer::upload_map_now(int k) {
    if (std::find(pending_maps_.begin(), pending_maps_.end(), k) == pending_maps_.end()) return;
    if (k == pending_maps_.front()) {  // perhaps under way: its remaining bands
        while (!pending_maps_.empty() && pending_maps_.front() == k) upload_pending_map(kPendingBandBytes);
        return;
    }
    finish_upload(k, upload_map(map_image(k), k < 0 ? "irradiance" : "reflection"));
}

bool Renderer::upload_pending_map(std::size_t max_bytes) {
    if (pending_maps_.empty()) return false;
    const int k = pending_maps_.front();
    if (!uploading_) {
        const HdrImage& image = map_image(k);
        if (image.empty()) throw RuntimeError(std::string("renderer: the ") + (k < 0 ? "irradiance" : "reflection") + " map is empty");
        uploading_.emplace(image);
    }
    if (uploading_->step(max_bytes)) {
        finish_upload(k, uploading_->take());
        uploading_.reset();
    }
    gl::check_gl("uploading a map");
    return true;
}

void Renderer::set_uniform_material(const Material& material) {
    if (material.diffuse() && !maps_->irradiance)
        throw RuntimeError("renderer: the material " + material.spec + " needs the irradiance map");
    const ReflectionMap* reflection = material.specular() ? maps_->reflection_for(material) : nullptr;
    if (material.specular() && !reflection)
        throw RuntimeError("renderer: the material " + material.spec + " needs the " + reflection_request(material).label + " map");
    Draw d;
    d.material = material;
    d.first_index = 0;
    d.index_count = index_total_;
    if (material.diffuse()) upload_map_now(-1);  // if it is still waiting
    if (reflection) {
        d.reflection = int(reflection - maps_->reflections.data());
        upload_map_now(d.reflection);
    }
    draws_.assign(1, std::move(d));
    gl::check_gl("changing the material");
}

std::vector<float> Renderer::read_frame_radiance() const { return read_target(kRadiance); }

Aovs Renderer::read_aovs() {
    // One sample a pixel (exact AOVs, also with MSAA), with the reflection target, in RGBA32F.
    draw(false, false, true, true);
    Aovs a;
    a.width = width_;
    a.height = height_;
    a.radiance = read_target(kRadiance, true);
    a.normal = read_target(kNormal, true);
    a.reflect = read_target(kReflect, true);
    if (shadow_) {
        draw_shadow();  // the ratio's own target: frames evaluate it in the composite
        a.shadow = shadow_->read();
    }
    return a;
}

void Renderer::set_table(double height) {
    if (!phantoms_) phantoms_ = std::make_unique<PhantomGeometry>();
    phantoms_->set_table(height);
    if (shadow_) shadow_->set_table_height(height);  // the shadow falls on the table where it is now
}

void Renderer::add_proxy(const Mesh& proxy) {
    if (!phantoms_) phantoms_ = std::make_unique<PhantomGeometry>();
    phantoms_->add_proxy(proxy);
}

void Renderer::enable_shadows(const ShadowLighting& lighting, std::vector<OccluderSphere> occluders) {
    if (!phantoms_ || !phantoms_->table_height())
        throw RuntimeError("renderer: shadows need the table (set_table) first");
    shadow_ = std::make_unique<TableShadowPass>(width_, height_, lighting, std::move(occluders),
                                                *phantoms_->table_height());
}

void Renderer::set_shadow_bake(const ShadowBake& bake) {
    if (!shadow_) throw RuntimeError("renderer: a baked shadow needs enable_shadows first");
    shadow_->set_bake(bake);
}

void Renderer::draw_shadow() const {
    if (!shadow_) return;
    const glm::mat3 world_from_camera(glm::transpose(glm::dmat3(view_matrix(camera_))));  // as set_camera_ray_uniforms
    const double ty = std::tan(glm::radians(camera_.fov_y_deg) / 2);
    shadow_->draw(world_from_camera, glm::vec2(float(ty * width_ / height_), float(ty)), glm::vec3(camera_.eye));
}

void Renderer::bind_shadow(const gl::GlProgram& program, int unit) const {
    glUniform1i(program.uniform("u_has_shadow"), shadow_ ? 1 : 0);
    if (shadow_) shadow_->set_uniforms(program, unit, glm::vec3(camera_.eye));
}

}  // namespace glint::render
