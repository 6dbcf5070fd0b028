// HDR image storage and input sanitising.
#include "appliance/core/hdr_image.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "appliance/core/errors.hpp"

namespace glint {

HdrImage::HdrImage(int width, int height) : HdrImage(width, height, Unwritten{}) {
    std::fill(data_.begin(), data_.end(), 0.0f);
}

HdrImage::HdrImage(int width, int height, Unwritten) : width_(width), height_(height) {
    if (width <= 0 || height <= 0)
        throw InputError("image size " + std::to_string(width) + "x" + std::to_string(height) +
                         " is empty");
    data_.resize(std::size_t(width) * std::size_t(height) * 3);
}

SanitiseCounts sanitise(HdrImage& image) {
    SanitiseCounts counts;
    for (float& v : image.data()) {
        if (std::isnan(v)) {
            ++counts.nan;
            v = 0.0f;
        } else if (std::isinf(v)) {
            if (v > 0) {
                ++counts.pos_inf;
                v = kMaxFiniteHalf;
            } else {
                ++counts.neg_inf;
                v = 0.0f;
            }
        } else if (v < 0.0f) {
            ++counts.negative;
            v = 0.0f;
        }
    }
    return counts;
}

}  // namespace glint
