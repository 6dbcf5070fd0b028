#include "appliance/capture/coverage.hpp"

#include <algorithm>
#include <cmath>

#include "appliance/core/errors.hpp"

namespace glint::capture {

namespace {
std::size_t at(int i, int j, int width) { return std::size_t(j) * std::size_t(width) + std::size_t(i); }
}  // namespace

CoverageReport measure_coverage(const std::vector<std::uint32_t>& samples, int width, int height, int min_samples,
                                double gap_radius_rad) {
    CoverageReport r;
    const std::vector<double> omega = row_solid_angles(width, height);
    // Unseen solid angle on a coarse grid (cells of about 5.6 degrees), for the gap search.
    const int cw = std::min(width, 64), ch = std::min(height, 32);
    std::vector<double> cell_unseen(std::size_t(cw) * std::size_t(ch), 0.0);
    double covered = 0;
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i) {
            const double o = omega[std::size_t(j)];
            if (samples[at(i, j, width)] >= std::uint32_t(min_samples))
                covered += o;
            else
                cell_unseen[at(i * cw / width, j * ch / height, cw)] += o;
        }
    r.covered_fraction = covered / (4 * kPi);
    const double cos_radius = std::cos(gap_radius_rad);
    struct Cell {
        glm::dvec3 d;
        double unseen;
    };
    std::vector<Cell> unseen_cells;
    for (int j = 0; j < ch; ++j)
        for (int i = 0; i < cw; ++i)
            if (cell_unseen[at(i, j, cw)] > 0) unseen_cells.push_back({texel_direction(i, j, cw, ch), cell_unseen[at(i, j, cw)]});
    if (unseen_cells.empty()) return r;
    for (int cj = 0; cj < ch; ++cj)
        for (int ci = 0; ci < cw; ++ci) {
            const glm::dvec3 centre = texel_direction(ci, cj, cw, ch);
            double unseen = 0;
            for (const Cell& c : unseen_cells)
                if (glm::dot(centre, c.d) >= cos_radius) unseen += c.unseen;
            if (unseen > r.largest_gap_sr) {
                r.largest_gap_sr = unseen;
                r.largest_gap = centre;
            }
        }
    return r;
}

std::vector<std::uint32_t> samples_with_summed_weight(std::vector<std::uint32_t> samples,
                                                      const std::vector<float>& weights, double min_weight) {
    if (weights.size() != samples.size()) throw RuntimeError("coverage: samples and weights differ in size");
    for (std::size_t k = 0; k < samples.size(); ++k)
        if (samples[k] == 0 && double(weights[k]) >= min_weight) samples[k] = 1;
    return samples;
}

long long fill_uncovered(HdrImage& img, const std::vector<std::uint32_t>& samples, int min_samples) {
    const int w = img.width(), h = img.height();
    const auto covered = [&](int i, int j) { return samples[at(i, j, w)] >= std::uint32_t(min_samples); };
    const std::vector<double> omega = row_solid_angles(w, h);
    double all[3] = {0, 0, 0}, all_w = 0, top[3] = {0, 0, 0}, bottom[3] = {0, 0, 0};
    int top_n = 0, bottom_n = 0;
    std::vector<int> first(std::size_t(w), -1), last(std::size_t(w), -1);
    for (int i = 0; i < w; ++i)
        for (int j = 0; j < h; ++j)
            if (covered(i, j)) {
                if (first[std::size_t(i)] < 0) first[std::size_t(i)] = j;
                last[std::size_t(i)] = j;
                const float* p = img.row(j) + 3 * i;
                for (int c = 0; c < 3; ++c) all[c] += p[c] * omega[std::size_t(j)];
                all_w += omega[std::size_t(j)];
            }
    if (all_w == 0) return 0;
    for (int i = 0; i < w; ++i) {
        if (first[std::size_t(i)] < 0) continue;
        const float* a = img.row(first[std::size_t(i)]) + 3 * i;
        const float* b = img.row(last[std::size_t(i)]) + 3 * i;
        for (int c = 0; c < 3; ++c) {
            top[c] += a[c];
            bottom[c] += b[c];
        }
        ++top_n;
        ++bottom_n;
    }
    long long filled = 0;
    const auto put = [&](int i, int j, const double* rgb) {
        float* p = img.row(j) + 3 * i;
        for (int c = 0; c < 3; ++c) p[c] = float(rgb[c]);
        ++filled;
    };
    for (int c = 0; c < 3; ++c) {
        all[c] /= all_w;
        top[c] /= std::max(1, top_n);
        bottom[c] /= std::max(1, bottom_n);
    }
    for (int i = 0; i < w; ++i) {
        const int f = first[std::size_t(i)], l = last[std::size_t(i)];
        if (f < 0) {
            for (int j = 0; j < h; ++j) put(i, j, all);
            continue;
        }
        for (int j = 0; j < f; ++j) put(i, j, top);
        for (int j = l + 1; j < h; ++j) put(i, j, bottom);
        // Interior gaps: linear in the row index (= in polar angle) between covered ends.
        int prev = f;
        for (int j = f + 1; j <= l; ++j) {
            if (!covered(i, j)) continue;
            if (j > prev + 1) {
                const float* a = img.row(prev) + 3 * i;
                const float* b = img.row(j) + 3 * i;
                const double ca[3] = {a[0], a[1], a[2]}, cb[3] = {b[0], b[1], b[2]};
                for (int g = prev + 1; g < j; ++g) {
                    const double t = double(g - prev) / double(j - prev);
                    const double v[3] = {ca[0] + t * (cb[0] - ca[0]), ca[1] + t * (cb[1] - ca[1]),
                                         ca[2] + t * (cb[2] - ca[2])};
                    put(i, g, v);
                }
            }
            prev = j;
        }
    }
    return filled;
}

HdrImage coverage_image(const std::vector<std::uint32_t>& samples, const std::vector<float>& weights, int width,
                        int height, int min_samples) {
    HdrImage img(width, height);
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i) {
            const std::size_t k = at(i, j, width);
            img.set(i, j, {float(samples[k]), weights[k], samples[k] >= std::uint32_t(min_samples) ? 1.0f : 0.0f});
        }
    return img;
}

}  // namespace glint::capture
