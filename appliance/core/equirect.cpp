// Equirectangular conventions: directions, texels, exact solid angles, bilinear lookup.
#include "appliance/core/equirect.hpp"

#include <algorithm>
#include <cmath>

namespace glint {

glm::dvec3 direction_from_angles(double theta, double phi) {
    const double st = std::sin(theta);
    return {st * std::sin(phi), std::cos(theta), -st * std::cos(phi)};
}

glm::dvec3 texel_direction(int i, int j, int width, int height) {
    return direction_from_angles(row_theta(j, height), column_phi(i, width));
}

TexelCoord direction_to_texel(const glm::dvec3& d, int width, int height) {
    const double phi = std::atan2(d.x, -d.z);                 // in [-pi, pi]
    const double theta = std::acos(std::clamp(d.y, -1.0, 1.0));  // in [0, pi]
    double x = (phi + kPi) / kTwoPi * width;
    if (x >= width) x -= width;  // phi = +pi is the same column as phi = -pi
    if (x < 0) x += width;
    return {x, theta / kPi * height};
}

double row_solid_angle(int j, int width, int height) {
    // cos(a) - cos(b) = 2 sin((a+b)/2) sin((b-a)/2): no cancellation near the poles.
    const double a = kPi * j / height;
    const double b = kPi * (j + 1) / height;
    return (kTwoPi / width) * 2.0 * std::sin(0.5 * (a + b)) * std::sin(0.5 * (b - a));
}

std::vector<double> row_solid_angles(int width, int height) {
    std::vector<double> out(static_cast<std::size_t>(height));
    for (int j = 0; j < height; ++j) out[std::size_t(j)] = row_solid_angle(j, width, height);
    return out;
}

Rgb sample_bilinear(const HdrImage& image, const glm::dvec3& d) {
    const int w = image.width();
    const int h = image.height();
    const TexelCoord t = direction_to_texel(d, w, h);
    // Texel centres sit at half-integers; shift so that integer coordinates are centres.
    const double x = t.x - 0.5;
    const double y = std::clamp(t.y - 0.5, 0.0, double(h - 1));
    const double fx0 = std::floor(x);
    const double fy0 = std::floor(y);
    const double ax = x - fx0;
    const double ay = y - fy0;
    int x0 = int(fx0) % w;
    if (x0 < 0) x0 += w;
    const int x1 = (x0 + 1) % w;
    const int y0 = int(fy0);
    const int y1 = std::min(y0 + 1, h - 1);
    const float* r0 = image.row(y0);
    const float* r1 = image.row(y1);
    float v[3];
    for (int c = 0; c < 3; ++c) {
        const double top = (1 - ax) * r0[3 * x0 + c] + ax * r0[3 * x1 + c];
        const double bottom = (1 - ax) * r1[3 * x0 + c] + ax * r1[3 * x1 + c];
        v[c] = float((1 - ay) * top + ay * bottom);
    }
    return {v[0], v[1], v[2]};
}

HdrImage resample_bilinear(const HdrImage& image, int width, int height) {
    if (image.width() == width && image.height() == height) return image;
    HdrImage out(width, height);
    for (int j = 0; j < height; ++j)
        for (int i = 0; i < width; ++i)
            out.set(i, j, sample_bilinear(image, texel_direction(i, j, width, height)));
    return out;
}

}  // namespace glint
