// A linear RGB radiance image in the equirectangular layout of docs/conventions.md:
// row 0 at the top, three float channels per texel, interleaved.
#pragma once

#include <cstddef>
#include <vector>

#include "appliance/core/buffer.hpp"

namespace glint {

struct Rgb {
    float r = 0, g = 0, b = 0;
};

class HdrImage {
public:
    // Not zeroed on allocation (buffer.hpp), so an image made Unwritten is first touched by the
    // threads that fill it, not by one thread's zero fill (on a VM a fresh page costs more than
    // writing it; docs/convolution.md, "Huge pages").
    using Storage = UninitVector<float>;
    // Marks a constructor whose texels are left unwritten, for a caller that writes all of them.
    struct Unwritten {};

    HdrImage() = default;
    HdrImage(int width, int height);  // zero-filled; throws InputError on a 0 or negative size
    HdrImage(int width, int height, Unwritten);  // every value must be written before it is read

    int width() const { return width_; }
    int height() const { return height_; }
    bool empty() const { return width_ == 0 || height_ == 0; }
    std::size_t texel_count() const { return std::size_t(width_) * std::size_t(height_); }

    float* row(int j) { return data_.data() + std::size_t(j) * std::size_t(width_) * 3; }
    const float* row(int j) const { return data_.data() + std::size_t(j) * std::size_t(width_) * 3; }
    Rgb at(int i, int j) const {
        const float* p = row(j) + 3 * i;
        return {p[0], p[1], p[2]};
    }
    void set(int i, int j, Rgb c) {
        float* p = row(j) + 3 * i;
        p[0] = c.r;
        p[1] = c.g;
        p[2] = c.b;
    }
    Storage& data() { return data_; }
    const Storage& data() const { return data_; }

private:
    int width_ = 0;
    int height_ = 0;
    Storage data_;
};

// Counts of texels changed by sanitise() (conventions: "Radiance files").
struct SanitiseCounts {
    std::size_t nan = 0;
    std::size_t pos_inf = 0;
    std::size_t neg_inf = 0;
    std::size_t negative = 0;  // finite and < 0
    std::size_t total() const { return nan + pos_inf + neg_inf + negative; }
};

// Largest finite half-float value; +Inf is clamped to it on load.
inline constexpr float kMaxFiniteHalf = 65504.0f;

// NaN and negatives (including -Inf) become 0, +Inf becomes kMaxFiniteHalf.
// Counts channel values, not texels.
SanitiseCounts sanitise(HdrImage& image);

}  // namespace glint
