// Synthetic camera frames of the board at a known pose, for the tests and the benchmark
// (docs/tracking.md "Rendered views"). Each output pixel averages s x s rays (supersampling) cast
// through the lens model (OpenCV's distortion, inverted per ray) onto the board plane, where the
// printed sheet is sampled bilinearly; beyond the sheet lies a grey table. Then the image
// conditions: light level, a glare blob, a hand-shaped occluder lying on the board, Gaussian
// blur, sensor noise, 8-bit quantisation. Corner positions are exact to a small fraction of a
// pixel, which is what the pose errors are measured against.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

#include "appliance/tracking/board.hpp"
#include "appliance/tracking/camera.hpp"

namespace glint::tracking {

struct ViewConditions {
    double blur_px = 0;        // Gaussian sigma, output pixels
    double noise = 0;          // noise sigma at mid grey, 8-bit codes (shot-noise-like: grows with level)
    double light = 1;          // exposure factor (1: white paper at code ~212)
    double glare = 0;          // peak added brightness of a glare blob (fraction of full scale), 0: none
    double hand_fraction = 0;  // share of the board's area covered by a hand, 0: none
};

class BoardRenderer {
public:
    // `board` must outlive the renderer.
    BoardRenderer(const Board& board, const Camera& camera, int supersample = 3, double texture_px_per_mm = 6);
    // Another printed sheet of the board's size (8-bit, `print_px_per_mm`), e.g. a board of
    // other markers for a comparison.
    BoardRenderer(const Board& board, const Camera& camera, const cv::Mat& print, double print_px_per_mm,
                  int supersample = 3);

    // An 8-bit grey frame of camera.width x camera.height of the board seen at `camera_from_board`.
    // `seed` picks the noise, the glare position and the hand's place and angle.
    cv::Mat render(const Pose& camera_from_board, const ViewConditions& conditions, std::uint64_t seed) const;

private:
    const Board& board_;
    Camera camera_;
    int supersample_;
    double texture_px_per_mm_;
    cv::Mat texture_;        // reflectance of the sheet, CV_32F
    cv::Mat ray_x_, ray_y_;  // undistorted normalised coordinates of every sub-pixel, CV_32F
};

}  // namespace glint::tracking
