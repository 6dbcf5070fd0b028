#pragma once
// Extrema of an array in eight independent lanes.
//
// One running `m = max(m, x)` over an array is a chain of dependent comparisons: each waits
// the comparison's latency (about 4 cycles) for the one before it, and the compiler may not
// split the chain by itself. Eight lanes let it run eight at once (or in one vector register).
// The extremum of the same entries in any order is the same value: results are identical to
// the single chain's over the same entries (NaN included).
#include <algorithm>
#include <cmath>
#include <cstddef>

namespace glint {

// The largest entry of v[0, count), or 0 if none is larger. NaN entries are passed over, as
// `m = std::max(m, x)` from m = 0 passes them over.
inline float largest_or_zero(const float* v, std::size_t count) {
    constexpr std::size_t kLanes = 8;
    float lane[kLanes] = {};
    std::size_t k = 0;
    for (; k + kLanes <= count; k += kLanes)
        for (std::size_t j = 0; j < kLanes; ++j) lane[j] = v[k + j] > lane[j] ? v[k + j] : lane[j];
    float m = 0.0f;
    for (; k < count; ++k) m = v[k] > m ? v[k] : m;
    for (float l : lane) m = std::max(m, l);
    return m;
}

// The largest |v[i]| of v[0, count), or 0 if none is larger. NaN entries are passed over.
inline double largest_magnitude(const double* v, std::size_t count) {
    constexpr std::size_t kLanes = 8;
    double lane[kLanes] = {};
    std::size_t k = 0;
    for (; k + kLanes <= count; k += kLanes)
        for (std::size_t j = 0; j < kLanes; ++j) {
            const double a = std::abs(v[k + j]);
            lane[j] = a > lane[j] ? a : lane[j];
        }
    double m = 0.0;
    for (; k < count; ++k) m = std::abs(v[k]) > m ? std::abs(v[k]) : m;
    for (double l : lane) m = std::max(m, l);
    return m;
}

// The smallest positive entry of v[0, count), or INFINITY if none. NaN entries are passed over.
inline double smallest_positive(const double* v, std::size_t count) {
    constexpr std::size_t kLanes = 8;
    double lane[kLanes];
    std::fill(lane, lane + kLanes, INFINITY);
    std::size_t k = 0;
    for (; k + kLanes <= count; k += kLanes)
        for (std::size_t j = 0; j < kLanes; ++j) {
            const double x = v[k + j];
            lane[j] = x > 0 && x < lane[j] ? x : lane[j];
        }
    double f = INFINITY;
    for (; k < count; ++k)
        if (v[k] > 0 && v[k] < f) f = v[k];
    for (double l : lane) f = std::min(f, l);
    return f;
}

}  // namespace glint
