// The extrema in lanes (lane_extrema.hpp) against one running comparison, the form they
// replaced (and fourier_pass.cpp's largest magnitude): every length around the lane count, NaN, infinities, negatives and zeros.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "appliance/core/lane_extrema.hpp"

namespace glint {
namespace {

float chain_largest_or_zero(const std::vector<float>& v, std::size_t count) {
    float m = 0.0f;
    for (std::size_t k = 0; k < count; ++k) m = std::max(m, v[k]);
    return m;
}

double chain_largest_magnitude(const std::vector<double>& v, std::size_t count) {
    double m = 0;
    for (std::size_t k = 0; k < count; ++k) m = std::max(m, std::abs(v[k]));
    return m;
}

double chain_smallest_positive(const std::vector<double>& v, std::size_t count) {
    double f = INFINITY;
    for (std::size_t k = 0; k < count; ++k)
        if (v[k] > 0) f = std::min(f, v[k]);
    return f;
}

TEST(LaneExtrema, EqualTheSingleChainOnEveryLengthAndSpecialValue) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> value(-2.0, 5.0);
    std::uniform_int_distribution<int> special(0, 9);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    for (int trial = 0; trial < 200; ++trial)
        for (std::size_t count = 0; count <= 40; ++count) {
            std::vector<double> d(count);
            std::vector<float> f(count);
            for (std::size_t k = 0; k < count; ++k) {
                switch (special(rng)) {
                    case 0: d[k] = nan; break;
                    case 1: d[k] = 0.0; break;
                    case 2: d[k] = -0.0; break;
                    case 3: d[k] = trial % 2 ? INFINITY : -INFINITY; break;
                    default: d[k] = value(rng);
                }
                f[k] = float(d[k]);
            }
            ASSERT_EQ(largest_or_zero(f.data(), count), chain_largest_or_zero(f, count)) << count;
            ASSERT_EQ(largest_magnitude(d.data(), count), chain_largest_magnitude(d, count)) << count;
            const double expect = chain_smallest_positive(d, count);
            ASSERT_EQ(smallest_positive(d.data(), count), expect) << count;
        }
}

TEST(LaneExtrema, FindTheExtremumWhereverItSits) {
    // In every lane and in the tail: a lane that is never combined would miss it.
    for (std::size_t count : {8u, 17u, 64u, 67u})
        for (std::size_t at = 0; at < count; ++at) {
            std::vector<float> f(count, 1.0f);
            std::vector<double> d(count, 3.0);
            f[at] = 9.0f;
            d[at] = 0.5;
            EXPECT_EQ(largest_or_zero(f.data(), count), 9.0f) << count << " " << at;
            EXPECT_EQ(smallest_positive(d.data(), count), 0.5) << count << " " << at;
            d[at] = -7.0;
            EXPECT_EQ(largest_magnitude(d.data(), count), 7.0) << count << " " << at;
        }
    EXPECT_EQ(largest_or_zero(nullptr, 0), 0.0f);
    EXPECT_EQ(smallest_positive(nullptr, 0), INFINITY);
    const std::vector<double> none(20, -1.0);
    EXPECT_EQ(smallest_positive(none.data(), none.size()), INFINITY);
}

}  // namespace
}  // namespace glint
