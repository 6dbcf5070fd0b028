// The GPU path of the HDR accumulation (hdr_accumulator.hpp): the same estimator and the same
// sampling, as a fragment shader over the map's texels (shaders/capture_accumulate.frag) adding
// into three float32 render targets by blending. The frame's linearised, box-filtered planes are
// computed on the CPU (HdrAccumulator::filtered_planes) and uploaded; the texel loop, the
// projection and the bilinear reads run on the GPU. Needs float render targets and
// GL_EXT_float_blend (both checked, with a clear error).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "appliance/capture/hdr_accumulator.hpp"
#include "appliance/render/gl_context.hpp"
#include "appliance/render/gl_program.hpp"
#include "appliance/render/gl_targets.hpp"

namespace glint::capture {

class GpuAccumulator {
public:
    // The context must be current on the calling thread for every call.
    GpuAccumulator(const render::GlContext& context, int width, int height, AccumulationSettings settings = {});

    void add_frame(const CameraFrame& frame, const CameraCalibration& calibration, const Quatd& world_from_camera);

    HdrImage radiance() const;                      // reads the targets back
    std::vector<std::uint32_t> samples() const;     // frames that sampled each texel
    std::vector<float> weights() const;
    int frames() const { return frames_; }

private:
    int width_, height_;
    AccumulationSettings settings_;
    render::RenderTargets targets_;
    render::GlProgram program_;
    render::GlVertexArray vao_;
    int frames_ = 0;
};

}  // namespace glint::capture
