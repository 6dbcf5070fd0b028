#include "appliance/convolution/gpu/gpu_engine.hpp"

#include <GLES3/gl3.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>
#include <set>

#include "appliance/convolution/lobe_sum.hpp"
#include "appliance/convolution/mipmap.hpp"
#include "appliance/convolution/sh.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/errors.hpp"

namespace glint::convolution::gpu {

namespace {

// A single-channel texture with nearest filtering: R32F (GL_RED, GL_FLOAT) or
// R32I (GL_RED_INTEGER, GL_INT); per-row parameters of a pass, masks.
gl::GlTexture make_channel_texture(int width, int height, GLenum internal, GLenum format, GLenum type,
                                       const void* data) {
    gl::GlTexture t = gl::GlTexture::create();
    glBindTexture(GL_TEXTURE_2D, t.id());
    glTexImage2D(GL_TEXTURE_2D, 0, GLint(internal), width, height, 0, format, type, data);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl::check_gl("creating a single-channel texture");
    return t;
}

gl::GlTexture make_row_texture(const std::vector<float>& values) {
    return make_channel_texture(int(values.size()), 1, GL_R32F, GL_RED, GL_FLOAT, values.data());
}

gl::GlTexture make_int_row_texture(const std::vector<int>& values) {
    return make_channel_texture(int(values.size()), 1, GL_R32I, GL_RED_INTEGER, GL_INT, values.data());
}

gl::GlTexture make_mask_texture(int width, int height, const std::vector<float>& mask) {
    return make_channel_texture(width, height, GL_R32F, GL_RED, GL_FLOAT, mask.data());
}

void bind_texture(int unit, GLuint texture) {
    glActiveTexture(GLenum(GL_TEXTURE0 + unit));
    glBindTexture(GL_TEXTURE_2D, texture);
}

HdrImage rgb_of(const std::vector<float>& rgba, int width, int height) {
    HdrImage image(width, height);
    for (int j = 0; j < height; ++j) {
        float* dst = image.row(j);
        const float* src = rgba.data() + std::size_t(j) * std::size_t(width) * 4;
        for (int i = 0; i < width; ++i) {
            dst[3 * i] = src[4 * i];
            dst[3 * i + 1] = src[4 * i + 1];
            dst[3 * i + 2] = src[4 * i + 2];
        }
    }
    return image;
}

// The cone's sums as GPU passes (shaders/convolve_cone.frag, convolve_bright.frag).
class GpuConeSums final : public ConeSumsBackend {
public:
    GpuConeSums(GpuEngine& engine, const PreparedLevel& level, Size out, double n, const ConeSettings& settings)
        : engine_(engine), out_(out), n_(n), width_(level.width()), height_(level.height()),
          classes_(out.width / std::gcd(level.width(), out.width)) {
        // The CPU's summer for this cone: the rows' merge factors and the largest cosines below
        // are its own, so both engines read each row alike.
        const LobeSummer summer(level, out.width, out.height, n, Accumulation::FloatRuns, settings.max_texel_arc,
                                settings.max_arc_roughness);
        // The level and the merged versions its rows read, side by side in one atlas.
        const std::vector<int>& merge = summer.merge_factors();
        std::set<int> factors(merge.begin(), merge.end());
        factors.insert(1);  // the level itself, as before
        int atlas_width = 0;
        std::vector<std::pair<int, const PreparedLevel*>> versions;
        for (int m : factors) {
            const PreparedLevel* v = m == 1 ? &level : &level.merged_columns(m);
            int k = 0;
            while ((1 << k) < m) ++k;
            merge_offset_[std::size_t(k)] = atlas_width;
            versions.emplace_back(atlas_width, v);
            atlas_width += v->width();
        }
        std::vector<float> atlas(std::size_t(atlas_width) * std::size_t(height_) * 4, 0.0f);
        for (const auto& [offset, v] : versions)
            for (int j = 0; j < height_; ++j)
                for (int c = 0; c < 3; ++c) {
                    const float* plane = v->plane(j, c);
                    for (int i = 0; i < v->width(); ++i)
                        atlas[(std::size_t(j) * std::size_t(atlas_width) + std::size_t(offset + i)) * 4 + std::size_t(c)] =
                            plane[i];
                }
        atlas_ = make_float_texture(atlas_width, height_, atlas.data());
        row_merge_ = make_int_row_texture(merge);
        merge_ = merge;
        // The largest cosine of every output row and class, as the CPU's sums take it.
        cmax_.resize(std::size_t(classes_) * std::size_t(out.height));
        std::vector<float> log_cmax(cmax_.size());
        for (int row = 0; row < out.height; ++row)
            for (int cls = 0; cls < classes_; ++cls) {
                const std::size_t rc = std::size_t(row) * std::size_t(classes_) + std::size_t(cls);
                cmax_[rc] = summer.cmax(row, cls);
                log_cmax[rc] = float(std::log(cmax_[rc]));
            }
        log_cmax_ = make_channel_texture(classes_, out.height, GL_R32F, GL_RED, GL_FLOAT, log_cmax.data());
    }

    LobeSums first_pass(const std::vector<int>& rows, double c0, const RowProgress& progress) override {
        std::vector<float> x_outer(std::size_t(out_.height), -1.0f);
        for (int row : rows) x_outer[std::size_t(row)] = float(1.0 - c0);
        RenderTargets targets(out_.width, out_.height, 1);
        run_cone(targets, x_outer, -1.0f, nullptr, nullptr);
        const std::vector<float> sums = targets.read(0);
        LobeSums s = make_sums();
        for (int row : rows) fill_row(s, row, sums, nullptr);
        if (progress) progress((long long)rows.size());
        return s;
    }

    LobeSums annulus(const std::vector<int>& rows, const std::vector<LobeSummer::ColumnRuns>& runs,
                     const std::vector<double>& cut, double c_inner) override {
        std::vector<float> x_outer(std::size_t(out_.height), -1.0f);
        std::vector<float> mask(std::size_t(out_.width) * std::size_t(out_.height), 0.0f);
        for (std::size_t k = 0; k < rows.size(); ++k) {
            x_outer[std::size_t(rows[k])] = float(1.0 - cut[k]);
            for (const auto& [a, b] : runs[k])
                for (int i = a; i < b; ++i) mask[std::size_t(rows[k]) * std::size_t(out_.width) + std::size_t(i)] = 1.0f;
        }
        const gl::GlTexture mask_texture = make_mask_texture(out_.width, out_.height, mask);
        std::vector<double> mask_share(std::size_t(out_.height), 0.0);
        for (int r = 0; r < out_.height; ++r) {
            double on = 0;
            for (int i = 0; i < out_.width; ++i) on += mask[std::size_t(r) * std::size_t(out_.width) + std::size_t(i)];
            mask_share[std::size_t(r)] = std::max(0.01, on / out_.width);  // masked-out texels cost a little too
        }
        RenderTargets targets(out_.width, out_.height, 1);
        run_cone(targets, x_outer, float(1.0 - c_inner), &mask_texture, &mask_share);
        const std::vector<float> sums = targets.read(0);
        LobeSums s = make_sums();
        for (int row : rows) fill_row(s, row, sums, &mask);
        return s;
    }

    void bright(const BrightScatter& scatter, const LobeSums& layout, const std::vector<int>& rows,
                UninitVector<double>& nb) override {
        const auto& texels = scatter.texels();
        std::vector<float> data(texels.size() * 8);
        for (std::size_t b = 0; b < texels.size(); ++b) {
            // Row b of a 2-wide texture: (direction, min cosine), (L dOmega, 0).
            float* d = data.data() + b * 8;
            d[0] = float(texels[b].x);
            d[1] = float(texels[b].y);
            d[2] = float(texels[b].z);
            d[3] = float(std::min(2.0, scatter.min_cos()[b]));
            d[4] = float(texels[b].r);
            d[5] = float(texels[b].g);
            d[6] = float(texels[b].b);
            d[7] = 0.0f;
        }
        const gl::GlTexture bright = make_float_texture(2, int(texels.size()), data.data());
        // Work of a texel of each row: the loop over every bright texel, plus
        // the terms of those whose cut-off cone reaches the row.
        std::vector<double> work(std::size_t(out_.height), double(texels.size()) + 1.0);
        for (std::size_t b = 0; b < texels.size(); ++b) {
            const double c = scatter.min_cos()[b];
            if (c > 1.0) continue;
            const double reach = std::acos(std::clamp(c, -1.0, 1.0));
            for (int r = 0; r < out_.height; ++r)
                // A term (exp, log, a fetch) costs ~20 times the loop's test.
                if (std::abs(kPi * (r + 0.5) / out_.height - texels[b].theta) <= reach) work[std::size_t(r)] += 20.0;
        }
        RenderTargets targets(out_.width, out_.height, 1);
        const gl::GlProgram& p = engine_.program("convolve_bright.frag");
        engine_.draw_tiled(p, targets, [&] {
            bind_texture(0, bright.id());
            bind_texture(1, log_cmax_.id());
            glUniform1i(p.uniform("u_bright"), 0);
            glUniform1i(p.uniform("u_log_cmax"), 1);
            glUniform1i(p.uniform("u_classes"), classes_);
            glUniform1i(p.uniform("u_count"), GLint(texels.size()));
            glUniform1f(p.uniform("u_n"), float(n_));
            glUniform2i(p.uniform("u_out_size"), out_.width, out_.height);
        }, &work);
        const std::vector<float> values = targets.read(0);
        for (int row : rows)
            for (int i = 0; i < out_.width; ++i) {
                const std::size_t t = std::size_t(row) * std::size_t(out_.width) + std::size_t(i);
                const std::size_t at = layout.texel(row, i);
                for (std::size_t c = 0; c < 3; ++c) nb[3 * at + c] = double(values[4 * t + c]);
            }
    }

private:
    LobeSums make_sums() const {
        LobeSums s;
        s.out_w = out_.width;
        s.out_h = out_.height;
        s.classes = classes_;
        s.num.resize(std::size_t(out_.width) * std::size_t(out_.height) * 3);
        s.den.assign(std::size_t(classes_) * std::size_t(out_.height), 0.0);
        s.cmax.assign(std::size_t(classes_) * std::size_t(out_.height), 0.0);
        return s;
    }

    // One output row of the targets into sums: numerators of every texel (of
    // the masked ones where a mask is given; the others 0), and per class the
    // denominator (the same for every texel of a class) and cmax.
    void fill_row(LobeSums& s, int row, const std::vector<float>& sums, const std::vector<float>* mask) const {
        for (int i = 0; i < out_.width; ++i) {
            const std::size_t t = std::size_t(row) * std::size_t(out_.width) + std::size_t(i);
            const bool on = !mask || (*mask)[t] > 0.5f;
            for (std::size_t c = 0; c < 3; ++c) s.num[3 * t + c] = on ? double(sums[4 * t + c]) : 0.0;
            const std::size_t rc = std::size_t(row) * std::size_t(classes_) + std::size_t(i % classes_);
            s.cmax[rc] = cmax_[rc];
            if (on) s.den[rc] = double(sums[4 * t + 3]);
        }
    }

    // mask, mask_share: the annulus pass's texels and each row's share of them.
    void run_cone(const RenderTargets& targets, const std::vector<float>& x_outer, float x_inner,
                  const gl::GlTexture* mask, const std::vector<double>* mask_share) {
        const gl::GlTexture rows = make_row_texture(x_outer);
        const gl::GlProgram& p = engine_.program("convolve_cone.frag");
        // Bands of level rows, added up by float blending (see exact()).
        const int band = engine_.band_rows(width_, height_);
        targets.bind();
        glClearColor(0, 0, 0, 0);
        glClear(GL_COLOR_BUFFER_BIT);
        engine_.begin_accumulation();
        for (int first = 0; first < height_; first += band) {
            const std::vector<double> work =
                row_work(x_outer, first, std::min(height_, first + band), mask_share);
            engine_.draw_tiled(p, targets, [&] {
                bind_texture(0, atlas_.id());
                bind_texture(1, row_merge_.id());
                bind_texture(2, rows.id());
                bind_texture(3, mask ? mask->id() : rows.id());
                bind_texture(4, log_cmax_.id());
                glUniform1i(p.uniform("u_atlas"), 0);
                glUniform1i(p.uniform("u_row_merge"), 1);
                glUniform1i(p.uniform("u_row_x_outer"), 2);
                glUniform1i(p.uniform("u_mask"), 3);
                glUniform1i(p.uniform("u_log_cmax"), 4);
                glUniform1i(p.uniform("u_use_mask"), mask ? 1 : 0);
                glUniform2i(p.uniform("u_level_size"), width_, height_);
                glUniform1iv(p.uniform("u_merge_offset"), 8, merge_offset_.data());
                glUniform2i(p.uniform("u_out_size"), out_.width, out_.height);
                glUniform1i(p.uniform("u_classes"), classes_);
                glUniform1f(p.uniform("u_n"), float(n_));
                glUniform1f(p.uniform("u_x_inner"), x_inner);
                glUniform1i(p.uniform("u_row_begin"), first);
                glUniform1i(p.uniform("u_row_end"), std::min(height_, first + band));
            }, &work);
        }
        glDisable(GL_BLEND);
    }

    // Terms a texel of each output row sums over the level rows [j_begin,
    // j_end): the shader's column ranges, counted on the CPU; times the share
    // of the row's texels that the mask lets through.
    std::vector<double> row_work(const std::vector<float>& x_outer, int j_begin, int j_end,
                                 const std::vector<double>* mask_share) const {
        std::vector<double> work(std::size_t(out_.height), 0.0);
        for (int r = 0; r < out_.height; ++r) {
            const double xo = x_outer[std::size_t(r)];
            if (xo < 0) continue;
            const double tr = kPi * (r + 0.5) / out_.height, str = std::sin(tr);
            double terms = 0;
            for (int j = j_begin; j < j_end; ++j) {
                const double tk = kPi * (j + 0.5) / height_, sdt = std::sin(0.5 * (tr - tk));
                const double rest = xo - 2.0 * sdt * sdt;
                if (rest < 0) continue;
                const int wm = width_ / merge_[std::size_t(j)];
                const double sp = str * std::sin(tk);
                const double half = sp > 1e-30 ? 2.0 * std::asin(std::min(1.0, std::sqrt(rest / (2.0 * sp)))) * wm / kTwoPi
                                               : double(wm);
                terms += std::min(double(wm), 2.0 * half + 3.0);
            }
            work[std::size_t(r)] = (terms + 1.0) * (mask_share ? (*mask_share)[std::size_t(r)] : 1.0);
        }
        return work;
    }

    GpuEngine& engine_;
    Size out_;
    double n_;
    int width_, height_, classes_;
    std::array<GLint, 8> merge_offset_{};
    gl::GlTexture atlas_, row_merge_, log_cmax_;
    std::vector<double> cmax_;  // per output row and class
    std::vector<int> merge_;    // merge factor of each level row
};

}  // namespace

GpuEngine::GpuEngine(const gl::GlContext& context, TileGate& gate, double hard_cap_ms)
    : context_(context), gate_(gate), hard_cap_ms_(hard_cap_ms),
      batch_(std::min(8, context.caps().max_draw_buffers)), vao_(gl::GlVertexArray::create()) {
    if (!context.caps().float_color_buffer)
        throw RuntimeError("GPU engine: this GL context lacks GL_EXT_color_buffer_float (float render targets, "
                           "needed to accumulate in 32-bit float); use the CPU engine");
}

void GpuEngine::prepare_programs() {
    for (const char* fragment :
         {"convolve_exact.frag", "convolve_cone.frag", "convolve_bright.frag", "convolve_mipmap.frag", "convolve_sh.frag"})
        program(fragment);
}

int GpuEngine::band_rows(int width, int height) const {
    // At most kBandTexels input texels per draw: llvmpipe ends a loop after
    // 65535 iterations (silently: the sums were short by 95 % at 1024x512),
    // and it bounds a draw's cost. Without GL_EXT_float_blend: one band.
    constexpr int kBandTexels = 16384;
    return context_.caps().float_blend ? std::max(1, kBandTexels / width) : height;
}

void GpuEngine::begin_accumulation() const {
    if (!context_.caps().float_blend) return;
    glEnable(GL_BLEND);
    glBlendEquation(GL_FUNC_ADD);
    glBlendFunc(GL_ONE, GL_ONE);
}

const gl::GlProgram& GpuEngine::program(const std::string& fragment) {
    for (const auto& [name, p] : programs_)
        if (name == fragment) return *p;
    programs_.emplace_back(fragment, std::make_unique<gl::GlProgram>("fullscreen.vert", fragment));
    return *programs_.back().second;
}

void GpuEngine::draw_tiled(const gl::GlProgram& program, const RenderTargets& targets,
                           const std::function<void()>& set_uniforms, const std::vector<double>* row_work) {
    targets.bind();
    program.use();
    glBindVertexArray(vao_.id());
    set_uniforms();
    gl::check_gl(("setting up the pass " + program.label()).c_str());
    TileRunner runner(context_.caps(), gate_, hard_cap_ms_, costs_[program.label()]);
    runner.run(
        targets.width(), targets.height(), [](const TileRect&) { glDrawArrays(GL_TRIANGLES, 0, 3); },
        [&](const TileRect& tile) {
            if (on_tile_) on_tile_(tile, targets.texture(0));
        },
        row_work);
    gl::check_gl(("drawing the pass " + program.label()).c_str());
    stats_.tiles += runner.stats().tiles;
    stats_.gpu_ms += runner.stats().gpu_ms;
    stats_.largest_ms = std::max(stats_.largest_ms, runner.stats().largest_ms);
}

std::vector<HdrImage> GpuEngine::exact(const HdrImage& input, const std::vector<double>& shininess, Size out) {
    if (shininess.empty() || int(shininess.size()) > batch_)
        throw RuntimeError("GPU engine: an exact pass takes 1 to " + std::to_string(batch_) + " maps");
    const gl::GlTexture texture = upload_image(input);
    RenderTargets targets(out.width, out.height, int(shininess.size()));
    const gl::GlProgram& p = program("convolve_exact.frag");
    std::array<float, 8> n{};
    for (std::size_t k = 0; k < shininess.size(); ++k) n[k] = float(shininess[k]);
    const int band = band_rows(input.width(), input.height());
    targets.bind();
    glClearColor(0, 0, 0, 0);
    glClear(GL_COLOR_BUFFER_BIT);
    begin_accumulation();
    for (int first = 0; first < input.height(); first += band) {
        draw_tiled(p, targets, [&] {
            bind_texture(0, texture.id());
            glUniform1i(p.uniform("u_input"), 0);
            glUniform2i(p.uniform("u_out_size"), out.width, out.height);
            glUniform1i(p.uniform("u_classes"), out.width / std::gcd(input.width(), out.width));
            glUniform1i(p.uniform("u_maps"), GLint(shininess.size()));
            glUniform1fv(p.uniform("u_n"), 8, n.data());
            glUniform1i(p.uniform("u_row_begin"), first);
            glUniform1i(p.uniform("u_row_end"), std::min(input.height(), first + band));
        });
    }
    glDisable(GL_BLEND);
    std::vector<HdrImage> images;
    for (int k = 0; k < int(shininess.size()); ++k) {
        const std::vector<float> sums = targets.read(k);
        HdrImage image(out.width, out.height);
        for (int j = 0; j < out.height; ++j)
            for (int i = 0; i < out.width; ++i) {
                const float* t = sums.data() + (std::size_t(j) * std::size_t(out.width) + std::size_t(i)) * 4;
                if (t[3] > 0) image.set(i, j, {t[0] / t[3], t[1] / t[3], t[2] / t[3]});
            }
        images.push_back(std::move(image));
    }
    return images;
}

std::vector<HdrImage> GpuEngine::mipmap(const Pyramid& pyramid, const std::vector<std::pair<bool, double>>& maps,
                                        Size out) {
    if (maps.empty() || int(maps.size()) > batch_)
        throw RuntimeError("GPU engine: a mipmap pass takes 1 to " + std::to_string(batch_) + " maps");
    std::map<int, gl::GlTexture> levels;
    const auto level_texture = [&](int k) {
        auto it = levels.find(k);
        if (it == levels.end()) it = levels.emplace(k, upload_image(pyramid.level(k))).first;
        return it->second.id();
    };
    struct Lookup {
        GLuint fine, coarse;
        float blend;
    };
    std::vector<Lookup> lookups;
    for (const auto& [irradiance, n] : maps) {
        const MipmapLookup l = mipmap_lookup(pyramid, irradiance, n);
        lookups.push_back({level_texture(l.fine), level_texture(l.coarse), float(l.blend)});
    }
    RenderTargets targets(out.width, out.height, int(maps.size()));
    const gl::GlProgram& p = program("convolve_mipmap.frag");
    draw_tiled(p, targets, [&] {
        std::array<GLint, 8> fine{}, coarse{};
        std::array<float, 8> blend{};
        for (int k = 0; k < 8; ++k) {
            const Lookup& l = lookups[std::size_t(std::min<std::size_t>(std::size_t(k), lookups.size() - 1))];
            bind_texture(2 * k, l.fine);
            bind_texture(2 * k + 1, l.coarse);
            fine[std::size_t(k)] = 2 * k;
            coarse[std::size_t(k)] = 2 * k + 1;
            blend[std::size_t(k)] = l.blend;
        }
        glUniform1iv(p.uniform("u_fine"), 8, fine.data());
        glUniform1iv(p.uniform("u_coarse"), 8, coarse.data());
        glUniform1fv(p.uniform("u_blend"), 8, blend.data());
        glUniform1i(p.uniform("u_maps"), GLint(maps.size()));
        glUniform2i(p.uniform("u_out_size"), out.width, out.height);
    });
    std::vector<HdrImage> images;
    for (int k = 0; k < int(maps.size()); ++k) images.push_back(rgb_of(targets.read(k), out.width, out.height));
    return images;
}

std::vector<double> GpuEngine::sh_evaluate(const ShCoefficients& c, int order, const std::vector<double>& kernel,
                                           Size out) {
    if (order < 1 || order > c.order || int(kernel.size()) < order)
        throw RuntimeError("GPU engine: SH order " + std::to_string(order) + " with " + std::to_string(c.order) +
                           " projected bands and " + std::to_string(kernel.size()) + " kernel bands");
    // The weighted coefficients and the recurrences, packed by column m.
    const std::size_t packed = std::size_t(order) * std::size_t(order + 1) / 2;
    constexpr std::size_t kWidth = 4096;
    const std::size_t rows = (packed + kWidth - 1) / kWidth;
    std::vector<float> cos_w(rows * kWidth * 4, 0.0f), sin_w(rows * kWidth * 4, 0.0f), steps(rows * kWidth * 4, 0.0f);
    std::vector<double> a(std::size_t(order) + 1), b(std::size_t(order) + 1);
    for (int m = 0; m < order; ++m) {
        const std::size_t first = std::size_t(m) * std::size_t(order) - std::size_t(m) * std::size_t(m - 1) / 2;
        sh_column_steps(order, m, a.data(), b.data());
        const double s_m = m == 0 ? 1.0 : std::sqrt(2.0);
        for (int l = m; l < order; ++l) {
            const std::size_t idx = first + std::size_t(l - m);
            const double w = kernel[std::size_t(l)] * s_m;
            for (int ch = 0; ch < 3; ++ch) {
                cos_w[4 * idx + std::size_t(ch)] = float(w * c.at(l, m, ch));
                if (m > 0) sin_w[4 * idx + std::size_t(ch)] = float(w * c.at(l, -m, ch));
            }
            if (l > m) {
                steps[4 * idx] = float(a[std::size_t(l - m)]);
                steps[4 * idx + 1] = float(b[std::size_t(l - m)]);
            }
        }
    }
    std::vector<float> pmm(std::size_t(order) * std::size_t(out.height) * 4, 0.0f);
    std::vector<double> diag(static_cast<std::size_t>(order));
    for (int j = 0; j < out.height; ++j) {
        sh_diagonal(order, std::sin(kPi * (j + 0.5) / out.height), diag.data());
        for (int m = 0; m < order; ++m) {
            const double v = diag[std::size_t(m)];
            // Below float's range the column is negligible (see the shader).
            pmm[(std::size_t(j) * std::size_t(order) + std::size_t(m)) * 4] = std::abs(v) < 1e-37 ? 0.0f : float(v);
        }
    }
    const gl::GlTexture cos_tex = make_float_texture(int(kWidth), int(rows), cos_w.data());
    const gl::GlTexture sin_tex = make_float_texture(int(kWidth), int(rows), sin_w.data());
    const gl::GlTexture steps_tex = make_float_texture(int(kWidth), int(rows), steps.data());
    const gl::GlTexture pmm_tex = make_float_texture(order, out.height, pmm.data());

    RenderTargets targets(out.width, out.height, 1);
    targets.bind();
    glClearColor(0, 0, 0, 0);
    glClear(GL_COLOR_BUFFER_BIT);
    begin_accumulation();
    const gl::GlProgram& p = program("convolve_sh.frag");
    // Bands of columns m with at most ~4096 recurrence steps per texel: one
    // texel of a band must stay far below the hard cap on any GPU.
    const bool blend = context_.caps().float_blend;
    int m0 = 0;
    while (m0 < order) {
        int m1 = m0;
        long long steps_in_band = 0;
        while (m1 < order && (!blend || m1 == m0 || steps_in_band + (order - m1) <= 4096)) {
            steps_in_band += order - m1;
            ++m1;
        }
        // Recurrence steps of a texel of each row in this band (columns whose
        // P_mm underflowed are skipped by the shader).
        std::vector<double> work(std::size_t(out.height), 1.0);
        for (int j = 0; j < out.height; ++j)
            for (int m = m0; m < m1; ++m)
                if (pmm[(std::size_t(j) * std::size_t(order) + std::size_t(m)) * 4] != 0.0f) work[std::size_t(j)] += order - m;
        draw_tiled(p, targets, [&] {
            bind_texture(0, cos_tex.id());
            bind_texture(1, sin_tex.id());
            bind_texture(2, steps_tex.id());
            bind_texture(3, pmm_tex.id());
            glUniform1i(p.uniform("u_cos_weights"), 0);
            glUniform1i(p.uniform("u_sin_weights"), 1);
            glUniform1i(p.uniform("u_steps"), 2);
            glUniform1i(p.uniform("u_pmm"), 3);
            glUniform1i(p.uniform("u_order"), order);
            glUniform1i(p.uniform("u_m_begin"), m0);
            glUniform1i(p.uniform("u_m_end"), m1);
            glUniform2i(p.uniform("u_out_size"), out.width, out.height);
        }, &work);
        m0 = m1;
    }
    glDisable(GL_BLEND);
    const std::vector<float> values = targets.read(0);
    std::vector<double> e(std::size_t(out.width) * std::size_t(out.height) * 3);
    for (std::size_t t = 0; t < std::size_t(out.width) * std::size_t(out.height); ++t)
        for (std::size_t ch = 0; ch < 3; ++ch) e[3 * t + ch] = double(values[4 * t + ch]);
    return e;
}

std::unique_ptr<ConeSumsBackend> GpuEngine::cone_sums(const PreparedLevel& level, Size out, double shininess,
                                                      const ConeSettings& settings) {
    return std::make_unique<GpuConeSums>(*this, level, out, shininess, settings);
}

}  // namespace glint::convolution::gpu
