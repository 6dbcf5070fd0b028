// The GPU path of the HDR accumulation (hdr_accumulator.hpp): the same estimator and the same
// sampling, as a fragment shader over the map's texels (shaders/capture_accumulate.frag) adding
// into three float32 render targets per exposure band (exposure_bands.hpp) by blending; the bands
// are read back and merged by the CPU's rule. The frame's linearised, box-filtered planes are
// computed on the CPU (HdrAccumulator::accumulation_planes) and uploaded; the texel loop, the
// projection and the bilinear reads run on the GPU. Needs float render targets and
// GL_EXT_float_blend (both checked, with a clear error).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "appliance/capture/hdr_accumulator.hpp"
#include "appliance/gl/gl_context.hpp"
#include "appliance/gl/gl_program.hpp"
#include "appliance/gl/gl_targets.hpp"

namespace glint::capture {

// The accumulation needs float render targets and float blending: throws RuntimeError naming the
// missing extension. The constructor checks it first; a command calls it to choose its engine.
void check_gpu_accumulation(const gl::GlContext& context);

class GpuAccumulator {
public:
    // The context must be current on the calling thread for every call.
    GpuAccumulator(const gl::GlContext& context, int width, int height, AccumulationSettings settings = {});

    // As HdrAccumulator::add_frame, the rolling shutter included (angular_velocity: camera frame,
    // rad/s).
    void add_frame(const CameraFrame& frame, const CameraCalibration& calibration, const glm::dquat& world_from_camera,
                   const glm::dvec3& angular_velocity = {});

    HdrImage radiance(int threads = 1) const;       // reads the targets back, merges rows on `threads`
    std::vector<std::uint32_t> samples() const;     // frames that sampled each texel
    std::vector<float> weights() const;
    int frames() const { return frames_; }

private:
    // One exposure band: targets num (t W X, alpha t W), den (W t^2), aux (W, sampled).
    struct Band {
        int index = 0;
        double t_min = 0;
        std::unique_ptr<gl::RenderTargets> targets;
    };
    Band& band_for(double t);
    std::vector<float> aux_sum(int component) const;  // aux summed over the bands, in map order

    int width_, height_;
    AccumulationSettings settings_;
    std::vector<Band> bands_;
    gl::GlProgram program_;
    gl::GlVertexArray vao_;
    int frames_ = 0;
};

}  // namespace glint::capture
