#include "appliance/capture/gpu_accumulator.hpp"

#include <algorithm>
#include <cmath>

#include "appliance/capture/exposure_bands.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"

namespace glint::capture {

void check_gpu_accumulation(const gl::GlContext& c) {
    if (!c.caps().float_color_buffer)
        throw RuntimeError("GPU accumulation: this GL context cannot render to float targets "
                           "(GL_EXT_color_buffer_float); use --engine cpu");
    if (!c.caps().float_blend)
        throw RuntimeError("GPU accumulation: this GL context cannot blend float targets (GL_EXT_float_blend); "
                           "use --engine cpu");
}

GpuAccumulator::GpuAccumulator(const gl::GlContext& context, int width, int height, AccumulationSettings settings)
    : width_(width),
      height_(height),
      settings_(settings),
      program_("fullscreen.vert", "capture_accumulate.frag"),
      vao_(gl::GlVertexArray::create()) {
    check_gpu_accumulation(context);
}

GpuAccumulator::Band& GpuAccumulator::band_for(double t) {
    return band_for_exposure(bands_, t, [&](int) {
        Band b;
        b.targets = std::make_unique<gl::RenderTargets>(width_, height_, 3);
        b.targets->bind();
        const float zero[4] = {0, 0, 0, 0};
        for (int k = 0; k < 3; ++k) glClearBufferfv(GL_COLOR, k, zero);
        gl::check_gl("clearing the accumulation targets of an exposure band");
        return b;
    });
}

void GpuAccumulator::add_frame(const CameraFrame& frame, const CameraCalibration& cal,
                               const glm::dquat& world_from_camera, const glm::dvec3& angular_velocity) {
    const Intrinsics& k = cal.intrinsics;
    const double t = frame.exposure_s * frame.total_gain() * cal.sensitivity;
    if (!(t > 0) || !std::isfinite(t))
        throw InputError("frame " + std::to_string(frame.sequence) + ": exposure x gain must be positive");
    const int s = settings_.downscale > 0 ? settings_.downscale : HdrAccumulator::auto_downscale(k, width_);
    int pw = 0, ph = 0;
    std::vector<std::uint8_t> zone;
    const std::vector<float> planes =
        HdrAccumulator::accumulation_planes(frame, cal, s, settings_.downscale <= 0, width_, pw, ph, &zone);
    std::vector<float> p(std::size_t(pw) * std::size_t(ph) * 4), w(p.size());
    constexpr std::size_t n = HdrAccumulator::kPlaneFloats;
    for (std::size_t i = 0; i < std::size_t(pw) * std::size_t(ph); ++i) {
        for (int c = 0; c < 3; ++c) {
            p[4 * i + std::size_t(c)] = planes[n * i + std::size_t(c)];
            w[4 * i + std::size_t(c)] = planes[n * i + 3 + std::size_t(c)];
        }
        p[4 * i + 3] = planes[n * i + 6];  // the invalid flag rides in X's alpha
        w[4 * i + 3] = zone.empty() ? 0.0f : float(zone[i]);  // the footprint zone in W's
    }
    const gl::GlTexture p_tex = gl::make_float_texture(pw, ph, p.data());
    const gl::GlTexture w_tex = gl::make_float_texture(pw, ph, w.data());

    band_for(t).targets->bind();
    program_.use();
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, p_tex.id());
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_2D, w_tex.id());
    glUniform1i(program_.uniform("u_p"), 0);
    glUniform1i(program_.uniform("u_w"), 1);
    const glm::dquat q = glm::conjugate(world_from_camera);  // camera_from_world
    glUniform4f(program_.uniform("u_camera_from_world"), float(q.x), float(q.y), float(q.z), float(q.w));
    glUniform4f(program_.uniform("u_focal_centre"), float(k.fx), float(k.fy), float(k.cx), float(k.cy));
    glUniform4f(program_.uniform("u_k1k2p1p2"), float(k.k1), float(k.k2), float(k.p1), float(k.p2));
    glUniform1f(program_.uniform("u_k3"), float(k.k3));
    glUniform2f(program_.uniform("u_image_size"), float(k.width), float(k.height));
    glUniform1i(program_.uniform("u_s"), s);
    glUniform1f(program_.uniform("u_t"), float(t));
    glUniform1f(program_.uniform("u_min_weight"), float(settings_.min_weight));
    glUniform2i(program_.uniform("u_map_size"), width_, height_);
    // The rolling shutter (rolling_shutter_project): the camera's angular velocity and each row's
    // time offset, (v - mid_row) x row_s. No readout: no motion to undo.
    const glm::dvec3 omega = cal.readout_s > 0 ? angular_velocity : glm::dvec3(0);
    glUniform3f(program_.uniform("u_omega"), float(omega.x), float(omega.y), float(omega.z));
    glUniform1f(program_.uniform("u_row_s"), float(cal.readout_s / k.height));
    glUniform1f(program_.uniform("u_mid_row"), float(0.5 * (k.height - 1)));
    glUniform1i(program_.uniform("u_taps"),
                zone.empty() ? 0 : HdrAccumulator::footprint_taps(HdrAccumulator::texel_box_width(k, width_, s)));
    // The same pre-distortion bound as project() (camera_model.cpp): far outside the image the
    // distortion polynomial folds back.
    glUniform1f(program_.uniform("u_limit_x"), float(std::max(k.cx, k.width - 1 - k.cx) / k.fx * 1.5 + 0.5));
    glUniform1f(program_.uniform("u_limit_y"), float(std::max(k.cy, k.height - 1 - k.cy) / k.fy * 1.5 + 0.5));
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE);
    glBindVertexArray(vao_.id());
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glDisable(GL_BLEND);
    gl::check_gl("accumulating a frame");
    ++frames_;
}

namespace {
// Texel (i, j) of the map is framebuffer row H-1-j (the shader flips): read back in map order.
std::size_t readback_index(int i, int j, int w, int h) {
    return (std::size_t(h - 1 - j) * std::size_t(w) + std::size_t(i)) * 4;
}
}  // namespace

HdrImage GpuAccumulator::radiance(int threads) const {
    std::vector<std::vector<float>> num, den, aux;
    for (const Band& b : bands_) {
        num.push_back(b.targets->read(0));
        den.push_back(b.targets->read(1));
        aux.push_back(b.targets->read(2));
    }
    HdrImage img(width_, height_);
    parallel_for(height_, threads, [&](int j) {
        std::vector<BandTexel> texel(bands_.size());
        for (int i = 0; i < width_; ++i) {
            const std::size_t k = readback_index(i, j, width_, height_);
            for (std::size_t b = 0; b < bands_.size(); ++b) {
                for (int c = 0; c < 3; ++c) {
                    texel[b].num[c] = num[b][k + std::size_t(c)];
                    texel[b].den[c] = den[b][k + std::size_t(c)];
                }
                texel[b].wt = num[b][k + 3];
                texel[b].clipped = den[b][k + 3];
                texel[b].reads = aux[b][k + 2];
                texel[b].t_min = bands_[b].t_min;
            }
            img.set(i, j, merge_bands(texel));
        }
    });
    return img;
}

std::vector<float> GpuAccumulator::aux_sum(int component) const {
    std::vector<float> out(std::size_t(width_) * std::size_t(height_), 0.0f);
    for (const Band& b : bands_) {
        const std::vector<float> aux = b.targets->read(2);
        for (int j = 0; j < height_; ++j)
            for (int i = 0; i < width_; ++i)
                out[std::size_t(j) * std::size_t(width_) + std::size_t(i)] +=
                    aux[readback_index(i, j, width_, height_) + std::size_t(component)];
    }
    return out;
}

std::vector<std::uint32_t> GpuAccumulator::samples() const {
    const std::vector<float> sampled = aux_sum(1);
    std::vector<std::uint32_t> out(sampled.size());
    for (std::size_t k = 0; k < sampled.size(); ++k) out[k] = std::uint32_t(std::lround(sampled[k]));
    return out;
}

std::vector<float> GpuAccumulator::weights() const { return aux_sum(0); }

}  // namespace glint::capture
