// The GPU engine: the same plans as the CPU engine (planner, SharedInputs,
// cone logic) with the heavy sums as fragment shaders over the output texels,
// in tiles (tile_runner.hpp). `exact` and `mipmap` share a pass between up to
// 8 maps of one output size (one RGBA32F render target each); the cone's
// first pass, its annuli and its bright texels run as passes of one map, and
// the CPU does the cone's bound and normalisation between them; SH maps are
// reconstructed on the GPU from the CPU's projection (the bound, bright
// texels and normalisation of the SH split stay on the CPU).
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "appliance/convolution/gpu/tile_runner.hpp"
#include "appliance/convolution/methods.hpp"
#include "appliance/gl/gl_context.hpp"
#include "appliance/gl/gl_targets.hpp"
#include "appliance/gl/gl_objects.hpp"
#include "appliance/gl/gl_program.hpp"

namespace glint::convolution::gpu {

// Float textures and render targets now live in appliance/gl (gl_targets.hpp).
using gl::make_float_texture;
using gl::RenderTargets;
using gl::upload_image;

class GpuEngine final : public MethodExecutor {
public:
    // Throws RuntimeError naming GL_EXT_color_buffer_float when the context
    // cannot render into float targets (the caller then uses the CPU engine).
    GpuEngine(const gl::GlContext& context, TileGate& gate, double hard_cap_ms = 50.0);

    int max_batch() const override { return batch_; }
    std::vector<HdrImage> exact(const HdrImage& input, const std::vector<double>& shininess, Size out) override;
    std::vector<HdrImage> mipmap(const Pyramid& pyramid, const std::vector<std::pair<bool, double>>& maps,
                                 Size out) override;
    std::unique_ptr<ConeSumsBackend> cone_sums(const PreparedLevel& level, Size out, double shininess,
                                               const ConeSettings& settings) override;
    std::vector<double> sh_evaluate(const ShCoefficients& c, int order, const std::vector<double>& kernel,
                                    Size out) override;

    // Called after every finished tile with the tile and the texture it was
    // drawn into (already flushed): a progress view can show the maps filling in.
    void on_tile(std::function<void(const TileRect&, GLuint)> callback) { on_tile_ = std::move(callback); }
    const TileStats& stats() const { return stats_; }
    void reset_stats() { stats_ = {}; }  // a long-lived engine counts each job apart

    // Draws `program` over every texel of `targets` in tiles. Used by the passes.
    // row_work: relative work of a texel of each output row (TileRunner).
    void draw_tiled(const gl::GlProgram& program, const RenderTargets& targets,
                    const std::function<void()>& set_uniforms, const std::vector<double>* row_work = nullptr);
    const gl::GlProgram& program(const std::string& fragment);
    // Compiles every program now (the driver may hold a lock while it compiles:
    // at start-up, not in the middle of a frame).
    void prepare_programs();
    // Input rows per draw of a width x height input (the passes sum bands of
    // rows and add them up), and the blending that adds them.
    int band_rows(int width, int height) const;
    void begin_accumulation() const;

private:
    const gl::GlContext& context_;
    TileGate& gate_;
    double hard_cap_ms_;
    int batch_;
    gl::GlVertexArray vao_;
    std::vector<std::pair<std::string, std::unique_ptr<gl::GlProgram>>> programs_;
    std::function<void(const TileRect&, GLuint)> on_tile_;
    std::map<std::string, TileCost> costs_;  // per program (its label)
    TileStats stats_;
};

}  // namespace glint::convolution::gpu
