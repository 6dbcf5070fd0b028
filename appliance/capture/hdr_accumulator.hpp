// HDR accumulation on the sphere: every environment texel inside a frame's frustum gets the
// frame's radiance estimate added with Robertson's weighting,
//     E = sum_f w_f t_f X_f / sum_f w_f t_f^2,
// where X_f is the frame's linear exposure at the texel (inverse response, vignetting divided
// out), t_f its exposure time x total gain x sensitivity, and w_f the weight of its code values
// (low near 0 and 255, zero when clipped). Frames at different auto-exposures merge into one
// radiance; a texel seen only clipped keeps no estimate from that frame.
//
// Sampling (docs/capture.md "Accumulation"): the frame is first linearised per pixel and box
// filtered to about one environment texel per pixel (factor s, from the focal length and the map
// width) into planes of X = mean(X) and W = mean(w) per cell. A texel reads both bilinearly at
// its projected position and adds t W X to the numerator and W t^2 to the denominator; round
// compact bright features it reads them over its whole footprint instead (footprint_read). The
// GPU path does the same with textures, so the two agree.
//
// Averaging X itself, not the premultiplied w X, matters at a sun: beside a pixel near
// saturation (code 246, w ~ 0.013) a rim pixel (w ~ 0.9) would otherwise take the whole cell or
// read. A cell is invalid when one of its pixels is clipped (code 255) in any channel, since its
// value is then only a lower bound, and a read that touches an invalid cell is no sample at all.
// A black pixel (code 0) is not: its bound is an upper one, near 0, and averaging it in is right
// (a bracket frame holds the sun in a few pixels amid black ones).
//
// The sums are kept per exposure band and merged per texel when the radiance is read
// (exposure_bands.hpp): a misregistered long exposure must not erase what only short ones hold. Beside a clipped sun the unclipped rim is far dimmer than what
// clipped, and with Robertson's t^2 a long exposure's biased read would outweigh the short
// exposures that hold the sun by (t_long / t_short)^2. Both effects together cost the sun of
// sunset.exr half of its energy (docs/capture.md "Saturation and the sun").
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "appliance/capture/camera_frame.hpp"
#include "appliance/capture/camera_model.hpp"
#include "appliance/capture/exposure_bands.hpp"
#include "appliance/core/hdr_image.hpp"

namespace glint::capture {

// Bracket fill: a frame's clipped reads are filled from the shorter frames that follow it within
// this time (its bracket: one readout apart, at most four), read at the same texel.
inline constexpr std::int64_t kBracketSpanNs = 100'000'000;

// A cell is bright enough for the footprint reads (not only 8x its dimmest neighbour) when one of
// its pixels could be this many read-noise standard deviations above zero (footprint_zone's noise
// floor): in a dark 320x180 frame about 5 pixels' brightest channel draws that much.
inline constexpr double kZoneNoiseSigmas = 4.0;

struct AccumulationSettings {
    int downscale = 0;            // box filter factor s; 0: about one map texel per pixel
    double min_weight = 0.02;     // a frame counts as a sample of a texel when its W reaches this
    // Fill a frame's clipped reads that have a weight of their own from the shorter frames of
    // its bracket (docs/capture.md, "Bracket fill"). Off by default: on seed 1 it brings the
    // stress set's two systematic sources within 2 % and studio, sunset to or below their figures
    // without it, but courtyard's sources within 2 % are 6 of 8 against 7, and seed 2 and the
    // rest of the stress set are not measured with it yet. The GPU accumulator does not fill.
    bool bracket_fill = false;
};

// A source still clipped in a frame at the sensor's shortest exposure: its energy cannot be
// measured, so it is estimated from its glare halo in the map (see "Estimated sources" below).
struct EstimatedSource {
    glm::dvec3 direction{0, 0, -1};  // centroid of the clipped region
    double clipped_solid_angle = 0;  // sr, the region filled with the estimate
    double source_radius_rad = 0;    // the fitted disc
    Rgb energy;                      // estimated sum L dOmega of the source (radiance x sr)
    Rgb lower_bound;                 // the clip level over the disc the region holds: what is certain
    bool fitted = false;             // false: the halo did not say more than the lower bound
};

struct FrameContribution {
    long long texels_in_view = 0;  // texels whose centre projects into the frame
    long long texels_sampled = 0;  // ... with a usable weight (counted as samples)
    int downscale = 1;
};

// The pixel a world direction is seen at by a rolling-shutter frame: the camera-frame direction
// `camera_dir` (seen with the frame's orientation) is turned by -angular_velocity x the time
// offset of the row it lands on, twice (the offset changes by well under a pixel's worth between
// the two: readout_s x angular speed / height), then projected. Without motion or readout, plain
// project(). nullopt as project() (outside the image by more than `margin`).
std::optional<PixelCoord> rolling_shutter_project(const CameraCalibration& calibration, const glm::dvec3& camera_dir,
                                                  const glm::dvec3& angular_velocity, double margin = 0.0);

class HdrAccumulator {
public:
    HdrAccumulator(int width, int height, AccumulationSettings settings = {});

    // world_from_camera is the frame's orientation at its timestamp (the middle row's
    // mid-exposure). With a rolling shutter (calibration.readout_s > 0) row v was exposed
    // calibration.row_time_offset_s(v) later, when the camera had turned on by angular_velocity
    // (camera frame, rad/s: the sensor's around the frame's time) x that time: each texel is read
    // at the row whose orientation sees it (rolling_shutter_view()).
    FrameContribution add_frame(const CameraFrame& frame, const CameraCalibration& calibration,
                                const glm::dquat& world_from_camera, int threads = 1,
                                const glm::dvec3& angular_velocity = {});

    // E per texel and channel; 0 where no frame gave a usable weight. Rows are merged on
    // `threads` threads (the merge is most of the time from a scan's last frame to its map).
    HdrImage radiance(int threads = 1) const;
    // The same, only for the texels within `margin_rad` of a camera's view (the rest of `image`
    // is left as it was): what a frame's drift correction reads, without merging the whole map.
    void update_radiance_in_view(HdrImage& image, const glm::dquat& world_from_camera, const Intrinsics& k,
                                 double margin_rad, int threads = 1) const;
    // Frames that sampled each texel with a usable weight (row-major).
    const std::vector<std::uint32_t>& samples() const { return samples_; }
    // Sum over frames of W per texel (mean of the three channels).
    const std::vector<float>& weights() const { return weight_sum_; }
    int width() const { return width_; }
    int height() const { return height_; }
    int frames() const { return frames_; }

    // Floats per grid cell of the planes: X_r X_g X_b W_r W_g W_b I, where I is 1 for an invalid
    // (clipped) cell and 0 otherwise.
    static constexpr int kPlaneFloats = 7;
    // The linearised, box-filtered planes of one frame (exposed for tests and the GPU path):
    // kPlaneFloats per output pixel.
    static std::vector<float> filtered_planes(const CameraFrame& frame, const CameraCalibration& calibration,
                                              int s, int& out_width, int& out_height);
    // Bilinear read of the planes at grid position (U, V) (clamped to the pixel centres): out[0..5]
    // = X_r X_g X_b W_r W_g W_b there, out[6] = 1 when one of the four cells read is invalid (the
    // read is then no sample), else 0.
    static void sample_planes(const std::vector<float>& planes, int width, int height, double U, double V,
                              double out[kPlaneFloats]);
    // Grid position of full-resolution pixel coordinates for the factor s.
    static double grid_coordinate(double pixel, int s) { return (pixel - 0.5 * (s - 1)) / s; }
    // The factor s for a camera and a map width.
    static int auto_downscale(const Intrinsics& k, int map_width);
    // A texel's height (pi / H = 2 pi / W) in grid cells at the image centre: the size of its
    // footprint in the planes (1.4 at 320 pixels over 70 degrees into 1024x512 with s = 1).
    static double texel_box_width(const Intrinsics& k, int map_width, int s);
    // Where point reads alias energy (compact bright cells, 8x their dimmest neighbour, or
    // clipped, and 2 cells round them), 1 per cell. There a texel reads the frame over its whole
    // footprint (footprint_read): a source smaller than a pixel then keeps its energy wherever it
    // falls between texel centres (docs/capture.md "Accumulation": with a point read 61-144 %, with
    // a box in the image's axes a spread of 14 % per frame, with the footprint 1 %).
    // With a noise floor (relative exposure), only cells above it count as bright (clipped ones
    // always do): accumulation_planes passes kZoneNoiseSigmas x the calibration's read noise over
    // the cell's s x s pixels, so that the noise of a dark frame is no bright feature.
    static std::vector<std::uint8_t> footprint_zone(const std::vector<float>& planes, int width, int height,
                                                    double noise_floor = 0);
    // Both zones in one pass: bit 0 the zone without a floor (what zone_weights takes: nonzero),
    // bit 1 the zone with `noise_floor` (footprint_zone's).
    static std::vector<std::uint8_t> footprint_zone_marks(const std::vector<float>& planes, int width, int height,
                                                          double noise_floor);
    // In the zone, each cell's weights W raised to the largest within 2 cells (not clipped ones):
    // one weight per frame over a compact source (hdr_accumulator.cpp says why).
    static void zone_weights(std::vector<float>& planes, int width, int height, const std::vector<std::uint8_t>& zone);
    // Taps per side of a texel's footprint read for a footprint of `box_cells` cells.
    static int footprint_taps(double box_cells);
    // What an accumulator of a map_width-wide map reads of a frame (the CPU's and the GPU's):
    // filtered_planes for the factor s and, when s was chosen automatically
    // (AccumulatorSettings::downscale <= 0) and a texel spans more than a cell, the footprint
    // zone into *zone (else *zone is emptied).
    static std::vector<float> accumulation_planes(const CameraFrame& frame, const CameraCalibration& calibration,
                                                  int s, bool automatic_downscale, int map_width, int& out_width,
                                                  int& out_height, std::vector<std::uint8_t>* zone = nullptr);

    // Exposure bands that hold frames, shortest first.
    int bands() const { return int(bands_.size()); }
    // Texel k's sums per band, shortest band first: what merge_bands reads there (diagnostics).
    std::vector<BandTexel> band_texels(std::size_t texel) const;

    // Estimated sources (docs/capture.md "Estimated sources"). A texel read clipped in a frame at
    // the calibration's shortest exposure (exposure x gain <= min_exposure_s) counts as a sample:
    // no exposure can measure it. radiance() fills each connected region of such texels with an
    // estimate: the source as a uniform disc whose glare halo (glare_fraction, glare_sigma_rad of
    // the calibration) is fitted to the map around the region, the halo then taken out of the map
    // and the disc's energy put into the region. The sources of the last radiance() call:
    const std::vector<EstimatedSource>& estimated_sources() const { return estimated_; }
    // Texels clipped at the shortest exposure (row-major, 0/1).
    const std::vector<std::uint8_t>& clipped_at_shortest() const { return clipped_short_; }

private:
    struct Band {
        int index = 0;  // exposure_band(t)
        double t_min = 0;
        std::vector<float> num;  // 3 per texel: sum W t X
        std::vector<float> den;  // 3 per texel: sum W t^2
        std::vector<float> wt;   // 1 per texel: sum W t
        std::vector<float> clipped;  // 1 per texel: reads of this band left out as clipped
        std::vector<float> reads;    // 1 per texel: reads of this band that did not clip
        std::vector<float> filled;   // 1 per texel: ... of which filled from a shorter frame (bracket fill)
    };
    Band& band_for(double t);
    Rgb merged(std::size_t texel, std::vector<BandTexel>& scratch) const;
    // Row j's columns [i0, i0 + count) (wrapping) within the cone cos(angle to axis) >= cos_limit;
    // false when the row has none. The frustum cull of add_frame.
    static bool cone_columns(int j, int width, int height, const glm::dvec3& axis, double cos_limit, int& i0,
                             int& count);

    int width_, height_;
    AccumulationSettings settings_;
    std::vector<Band> bands_;
    std::vector<std::uint32_t> samples_;
    std::vector<float> weight_sum_;
    int frames_ = 0;
    // Bracket fill (docs/capture.md, "Bracket fill"): a frame's clipped reads wait here for the
    // next, shorter frame of its bracket, whose read of the same texel is then added to the
    // clipped frame's band in its place. Up to 8 frames wait at once (a parent and its brackets).
    struct PendingFrame {
        int band_index = 0;     // exposure_band of the clipped frame
        double t = 0;           // its exposure x gain x sensitivity
        std::int64_t t_ns = 0;  // its time
    };
    std::vector<PendingFrame> pending_;       // slot -> frame; a slot with t == 0 is free
    std::vector<std::uint8_t> pending_mask_;  // per texel: the slots whose frame clipped it
    // Per slot and texel: the clipped read's own weight W (mean of the channels; in the footprint
    // zone a cell's W is its neighbourhood's, so a clipped cell has one), which the filled read
    // takes: the fill then weighs a frame as its unclipped reads of the texel are weighed.
    std::vector<float> pending_w_;
    std::vector<std::uint8_t> clipped_short_;
    double clip_radiance_ = 0;  // radiance that clips at the shortest exposure (centre of the image)
    double glare_fraction_ = 0, glare_sigma_rad_ = 0, pixel_rad_ = 0;
    bool box_spreads_ = false;  // the texel box spreads a clipped cell to its neighbours
    mutable std::vector<EstimatedSource> estimated_;
    void estimate_clipped_sources(HdrImage& image) const;
    static bool in_zone(const std::vector<std::uint8_t>& zone, int width, int height, double U, double V);
    // The trigonometry of the texel grid (made in the constructor) and of the footprint's taps
    // (for the taps of the frames seen), which depends on the row or the column only: made once,
    // not per texel and frame.
    // The same expressions as computed in place, so the sums are bit for bit what they were.
    struct SubRow {
        double w_row, cos_t, sin_t;  // the sub-row's weight and its tap's polar cosine and sine
    };
    std::vector<double> row_sin_, row_cos_, column_sin_, column_cos_;  // texel centres
    int trig_taps_ = 0;
    std::vector<std::vector<SubRow>> sub_rows_;   // per row j
    std::vector<double> tap_sin_, tap_cos_;       // per column i, taps_ entries: the taps' azimuths
    void prepare_footprint_trig(int taps);
    // Texel (i, j)'s read over its footprint into P (kPlaneFloats), replacing the centre's.
    void footprint_read(const std::vector<float>& planes, int pw, int ph, int s, const CameraCalibration& cal,
                        const glm::dquat& camera_from_world, const glm::dvec3& angular_velocity, int i, int j,
                        int taps, double P[kPlaneFloats]) const;
};

}  // namespace glint::capture
