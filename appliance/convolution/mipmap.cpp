// Solid-angle pyramid and the thesis' MIP-mapping lookup (Method B, §4.2) on equirect maps.
#include "appliance/convolution/mipmap.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "appliance/convolution/output_grid.hpp"
#include "appliance/core/equirect.hpp"
#include "appliance/core/parallel.hpp"
#include "appliance/core/errors.hpp"

namespace glint::convolution {
namespace {

HdrImage halve(const HdrImage& fine, int threads) {
    const int fw = fine.width();
    const int fh = fine.height();
    const std::vector<double> omega = row_solid_angles(fw, fh);
    HdrImage coarse(fw / 2, fh / 2);
    parallel_for(coarse.height(), threads, [&](int j) {
        const double oa = omega[std::size_t(2 * j)];
        const double ob = omega[std::size_t(2 * j + 1)];
        // Each child row contributes two texels of its own solid angle.
        const double inv_total = 1.0 / (2.0 * (oa + ob));
        const float* a = fine.row(2 * j);
        const float* b = fine.row(2 * j + 1);
        float* out = coarse.row(j);
        for (int i = 0; i < coarse.width(); ++i) {
            // The children are columns 2i and 2i + 1: floats 6i..6i+2 and 6i+3..6i+5.
            for (int c = 0; c < 3; ++c) {
                const std::size_t left = std::size_t(6 * i + c);
                const std::size_t right = left + 3;
                const double sum_a = double(a[left]) + double(a[right]);
                const double sum_b = double(b[left]) + double(b[right]);
                out[3 * i + c] = float((oa * sum_a + ob * sum_b) * inv_total);
            }
        }
    });
    return coarse;
}

}  // namespace

namespace {
void level_index_check(int k, int levels) {
    if (k < 0 || k >= levels)
        throw std::out_of_range("pyramid level " + std::to_string(k) + " of " + std::to_string(levels));
}
}  // namespace

Pyramid::Pyramid(HdrImage level0, int threads, Build build) : threads_(threads) {
    if (level0.empty()) throw InputError("cannot build a pyramid of an empty map");
    levels_.resize(level_sizes({level0.width(), level0.height()}).size());
    released_.assign(levels_.size(), 0);
    levels_[0] = std::move(level0);
    built_ = 1;
    if (build == Build::AllLevels) build_through(levels() - 1);
}

void Pyramid::build_through(int k) const {
    for (; built_ <= k; ++built_) {
        const std::size_t next = std::size_t(built_);
        if (released_[next])
            throw std::logic_error("pyramid level " + std::to_string(built_) + " was released before it was built");
        if (released_[next - 1])
            throw std::logic_error("pyramid level " + std::to_string(built_) + " is built from level " +
                                   std::to_string(built_ - 1) + ", which was released");
        const HdrImage& finer = levels_[next - 1];
        levels_[next] = finer.width() % 2 == 0 && finer.height() % 2 == 0
                            ? halve(finer, threads_)
                            : filter_to_footprint(finer, {(finer.width() + 1) / 2, (finer.height() + 1) / 2}, threads_);
    }
}

std::vector<Size> Pyramid::level_sizes(Size level0) {
    std::vector<Size> sizes{level0};
    while (sizes.back().height >= 2)
        sizes.push_back({(sizes.back().width + 1) / 2, (sizes.back().height + 1) / 2});
    return sizes;
}

void Pyramid::release_level(int k, bool coarser_read) {
    level_index_check(k, levels());
    const std::lock_guard lock(mutex_);
    if (coarser_read) build_through(std::min(k + 1, levels() - 1));  // the next level is made from this one
    levels_[std::size_t(k)] = HdrImage();
    released_[std::size_t(k)] = 1;
}

bool Pyramid::released(int k) const {
    level_index_check(k, levels());
    const std::lock_guard lock(mutex_);
    return released_[std::size_t(k)] != 0;
}

const HdrImage& Pyramid::level(int k) const {
    level_index_check(k, levels());
    const std::lock_guard lock(mutex_);
    if (released_[std::size_t(k)])
        throw std::logic_error("pyramid level " + std::to_string(k) + " was released and is read again");
    build_through(k);
    // levels_ never grows or shrinks after the constructor: the reference stays valid.
    return levels_[std::size_t(k)];
}

double mipmap_level(int input_height, bool irradiance, double shininess) {
    const double h = double(input_height);
    const double l_max = std::log2(h);
    if (irradiance) return l_max - 2.0;
    // The thesis divides s by 2 to fit its results to the accurate ones.
    return l_max - std::log2(std::min(std::max(shininess / 2.0, 4.0), h));
}

MipmapLookup mipmap_lookup(const Pyramid& pyramid, bool irradiance, double shininess) {
    const double level = std::clamp(mipmap_level(pyramid.level(0).height(), irradiance, shininess),
                                    0.0, double(pyramid.levels() - 1));
    const int k0 = int(std::floor(level));
    const int k1 = std::min(k0 + 1, pyramid.levels() - 1);
    const double t = level - double(k0);
    return {k0, k1, (t > 0 && k1 != k0) ? t : 0.0};
}

HdrImage mipmap_convolve(const Pyramid& pyramid, bool irradiance, double shininess, int out_width,
                         int out_height) {
    if (!irradiance && !(shininess >= 0))
        throw InputError("shininess " + std::to_string(shininess) + " is not >= 0");
    HdrImage out(out_width, out_height);

    const MipmapLookup lookup = mipmap_lookup(pyramid, irradiance, shininess);
    const HdrImage& fine = pyramid.level(lookup.fine);
    const HdrImage& coarse = pyramid.level(lookup.coarse);
    const double t = lookup.blend;
    const bool blend = t > 0;

    // Texel centre directions, separable: angles per column and per row once.
    const auto columns = static_cast<std::size_t>(out_width);
    std::vector<double> sin_phi(columns), cos_phi(columns);
    for (int i = 0; i < out_width; ++i) {
        const double phi = column_phi(i, out_width);
        sin_phi[std::size_t(i)] = std::sin(phi);
        cos_phi[std::size_t(i)] = std::cos(phi);
    }
    for (int j = 0; j < out_height; ++j) {
        const double theta = row_theta(j, out_height);
        const double st = std::sin(theta);
        const double ct = std::cos(theta);
        for (int i = 0; i < out_width; ++i) {
            const glm::dvec3 d(st * sin_phi[std::size_t(i)], ct, -st * cos_phi[std::size_t(i)]);
            const Rgb a = sample_bilinear(fine, d);
            if (!blend) {
                out.set(i, j, a);
                continue;
            }
            const Rgb b = sample_bilinear(coarse, d);
            out.set(i, j, {float((1 - t) * a.r + t * b.r), float((1 - t) * a.g + t * b.g),
                           float((1 - t) * a.b + t * b.b)});
        }
    }
    return out;
}

}  // namespace glint::convolution
