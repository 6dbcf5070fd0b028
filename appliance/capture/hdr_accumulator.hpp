// HDR accumulation on the sphere: every environment texel inside a frame's frustum gets the
// frame's radiance estimate added with Robertson's weighting,
//     E = sum_f w_f t_f X_f / sum_f w_f t_f^2,
// where X_f is the frame's linear exposure at the texel (inverse response, vignetting divided
// out), t_f its exposure time x total gain x sensitivity, and w_f the weight of its code values
// (low near 0 and 255, zero when clipped). Frames at different auto-exposures merge into one
// radiance; a texel seen only clipped keeps no estimate from that frame.
//
// Sampling (docs/capture.md "Accumulation"): the frame is first linearised per pixel and box
// filtered, weighted, to about one environment texel per pixel (factor s, from the focal length
// and the map width), as premultiplied planes P = mean(w X) and W = mean(w). A texel then reads
// P and W bilinearly at its projected position: X = P / W, w = W. The GPU path does the same
// with textures, so the two agree.
#pragma once

#include <cstdint>
#include <vector>

#include "appliance/capture/camera_frame.hpp"
#include "appliance/capture/camera_model.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::capture {

struct AccumulationSettings {
    int downscale = 0;            // box filter factor s; 0: about one map texel per pixel
    double min_weight = 0.02;     // a frame counts as a sample of a texel when its W reaches this
};

struct FrameContribution {
    long long texels_in_view = 0;  // texels whose centre projects into the frame
    long long texels_sampled = 0;  // ... with a usable weight (counted as samples)
    int downscale = 1;
};

class HdrAccumulator {
public:
    HdrAccumulator(int width, int height, AccumulationSettings settings = {});

    FrameContribution add_frame(const CameraFrame& frame, const CameraCalibration& calibration,
                                const Quatd& world_from_camera, int threads = 1);

    // E per texel and channel; 0 where no frame gave a usable weight.
    HdrImage radiance() const;
    // Frames that sampled each texel with a usable weight (row-major).
    const std::vector<std::uint32_t>& samples() const { return samples_; }
    // Sum over frames of W per texel (mean of the three channels).
    const std::vector<float>& weights() const { return weight_sum_; }
    int width() const { return width_; }
    int height() const { return height_; }
    int frames() const { return frames_; }

    // The linearised, box-filtered planes of one frame (exposed for tests and the GPU path):
    // 6 floats per output pixel, P_r P_g P_b W_r W_g W_b.
    static std::vector<float> filtered_planes(const CameraFrame& frame, const CameraCalibration& calibration,
                                              int s, int& out_width, int& out_height);
    // Bilinear read of the planes at grid position (U, V) (clamped to the pixel centres): out[6]
    // = P_r P_g P_b W_r W_g W_b there.
    static void sample_planes(const std::vector<float>& planes, int width, int height, double U, double V,
                              double out[6]);
    // Grid position of full-resolution pixel coordinates for the factor s.
    static double grid_coordinate(double pixel, int s) { return (pixel - 0.5 * (s - 1)) / s; }
    // The factor s for a camera and a map width.
    static int auto_downscale(const Intrinsics& k, int map_width);

private:
    int width_, height_;
    AccumulationSettings settings_;
    std::vector<double> num_;  // 3 per texel: sum w t X
    std::vector<double> den_;  // 3 per texel: sum w t^2
    std::vector<std::uint32_t> samples_;
    std::vector<float> weight_sum_;
    int frames_ = 0;
};

}  // namespace glint::capture
