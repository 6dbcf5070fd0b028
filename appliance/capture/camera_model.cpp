#include "appliance/capture/camera_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace glint::capture {

Intrinsics Intrinsics::from_fov(int width, int height, double horizontal_fov_rad) {
    Intrinsics k;
    k.width = width;
    k.height = height;
    k.fx = k.fy = 0.5 * width / std::tan(0.5 * horizontal_fov_rad);
    k.cx = 0.5 * (width - 1);
    k.cy = 0.5 * (height - 1);
    return k;
}

void distort(const Intrinsics& k, double x, double y, double& xd, double& yd) {
    const double r2 = x * x + y * y;
    const double radial = 1 + r2 * (k.k1 + r2 * (k.k2 + r2 * k.k3));
    xd = x * radial + 2 * k.p1 * x * y + k.p2 * (r2 + 2 * x * x);
    yd = y * radial + k.p1 * (r2 + 2 * y * y) + 2 * k.p2 * x * y;
}

void undistort(const Intrinsics& k, double xd, double yd, double& x, double& y) {
    // The fixed point (cv::undistortPoints' iteration) x = (xd - tangential) / radial: cheap and
    // enough for mild lenses, but its rate is the radial term's slope, so at the corners of a wide
    // lens (90 degrees across with k1 = -0.4, k2 = 0.2) it stopped 100-300 pixels short after 20
    // steps. Newton's steps on distort(x, y) = (xd, yd) finish from wherever it stopped.
    x = xd;
    y = yd;
    bool converged = false;
    for (int it = 0; it < 20 && !converged; ++it) {
        const double r2 = x * x + y * y;
        const double radial = 1 + r2 * (k.k1 + r2 * (k.k2 + r2 * k.k3));
        const double dx = 2 * k.p1 * x * y + k.p2 * (r2 + 2 * x * x);
        const double dy = k.p1 * (r2 + 2 * y * y) + 2 * k.p2 * x * y;
        const double nx = (xd - dx) / radial;
        const double ny = (yd - dy) / radial;
        converged = std::abs(nx - x) < 1e-12 && std::abs(ny - y) < 1e-12;
        x = nx;
        y = ny;
    }
    if (converged && std::isfinite(x) && std::isfinite(y)) return;
    // Newton from the better of the fixed point's end and the distorted point itself, each step
    // halved until the residual falls (a step across the radial curve's turning point would not).
    const auto residual = [&](double px, double py, double& ex, double& ey) {
        double qx = 0, qy = 0;
        distort(k, px, py, qx, qy);
        ex = qx - xd;
        ey = qy - yd;
        const double e = ex * ex + ey * ey;
        return std::isfinite(e) ? e : std::numeric_limits<double>::infinity();
    };
    double ex = 0, ey = 0;
    double e = std::isfinite(x) && std::isfinite(y) ? residual(x, y, ex, ey) : std::numeric_limits<double>::infinity();
    {
        double sx = 0, sy = 0;
        const double e0 = residual(xd, yd, sx, sy);
        if (!(e <= e0)) {
            x = xd;
            y = yd;
            e = e0;
            ex = sx;
            ey = sy;
        }
    }
    for (int it = 0; it < 50 && e > 1e-26; ++it) {
        const double r2 = x * x + y * y;
        const double radial = 1 + r2 * (k.k1 + r2 * (k.k2 + r2 * k.k3));
        const double slope = k.k1 + r2 * (2 * k.k2 + 3 * k.k3 * r2);  // d radial / d r2
        const double jxx = radial + 2 * x * x * slope + 2 * k.p1 * y + 6 * k.p2 * x;
        const double jxy = 2 * x * y * slope + 2 * k.p1 * x + 2 * k.p2 * y;
        const double jyy = radial + 2 * y * y * slope + 6 * k.p1 * y + 2 * k.p2 * x;
        const double det = jxx * jyy - jxy * jxy;  // the Jacobian is symmetric
        if (!(std::abs(det) > 1e-300)) break;
        const double stepx = (jyy * ex - jxy * ey) / det, stepy = (jxx * ey - jxy * ex) / det;
        bool better = false;
        for (double scale = 1; scale > 1e-6 && !better; scale *= 0.5) {
            const double nx = x - scale * stepx, ny = y - scale * stepy;
            double nex = 0, ney = 0;
            const double ne = residual(nx, ny, nex, ney);
            if (ne < e) {
                x = nx;
                y = ny;
                e = ne;
                ex = nex;
                ey = ney;
                better = true;
            }
        }
        if (!better) break;
    }
}

std::optional<PixelCoord> project(const Intrinsics& k, const glm::dvec3& d, double margin) {
    if (!(d.z < 0)) return std::nullopt;
    // One division: the accumulation projects every texel's taps three times a frame.
    const double inv_depth = 1.0 / -d.z;
    // A depth too small for its reciprocal, or a focal length no calibration has: nothing seen.
    if (!std::isfinite(inv_depth) || !(k.fx > 0 && k.fy > 0)) return std::nullopt;
    const double x = d.x * inv_depth;
    const double y = -d.y * inv_depth;
    // Far outside the image the distortion polynomial folds back; reject before evaluating it:
    // |x| beyond (the farther edge + margin) / f x 1.5 + 0.5, compared times f (f > 0).
    const double limit_x = (std::max(k.cx, k.width - 1 - k.cx) + margin) * 1.5 + 0.5 * k.fx;
    const double limit_y = (std::max(k.cy, k.height - 1 - k.cy) + margin) * 1.5 + 0.5 * k.fy;
    if (std::abs(x) * k.fx > limit_x || std::abs(y) * k.fy > limit_y) return std::nullopt;
    double xd = 0, yd = 0;
    distort(k, x, y, xd, yd);
    const PixelCoord p{k.fx * xd + k.cx, k.fy * yd + k.cy};
    if (p.u < -margin || p.v < -margin || p.u > k.width - 1 + margin || p.v > k.height - 1 + margin)
        return std::nullopt;
    return p;
}

glm::dvec3 pixel_ray(const Intrinsics& k, double u, double v) {
    double x = 0, y = 0;
    undistort(k, (u - k.cx) / k.fx, (v - k.cy) / k.fy, x, y);
    const double n = std::sqrt(x * x + y * y + 1);
    return {x / n, -y / n, -1 / n};
}

double min_cos_to_axis(const Intrinsics& k) {
    double c = 1;
    // The widest ray leaves through the border: check corners and edge midpoints.
    const double us[3] = {0, k.cx, double(k.width - 1)};
    const double vs[3] = {0, k.cy, double(k.height - 1)};
    for (double u : us)
        for (double v : vs) c = std::min(c, -pixel_ray(k, u, v).z);
    return c;
}

double Vignetting::at(const Intrinsics& k, double u, double v) const {
    const double half_diag = 0.5 * std::hypot(double(k.width), double(k.height));
    const double r2 = ((u - k.cx) * (u - k.cx) + (v - k.cy) * (v - k.cy)) / (half_diag * half_diag);
    return 1 + r2 * (a1 + r2 * (a2 + r2 * a3));
}

Response Response::parametric(double gamma, double shoulder) {
    Response r;
    r.gamma = gamma;
    r.shoulder = shoulder;
    // Code Z covers forward values [Z - 0.5, Z + 0.5); its centre inverts to the exposure below.
    for (int z = 0; z < 256; ++z) {
        const double y = std::clamp(double(z), 0.25, 254.75) / (255.0 * (1 + shoulder));
        const double root = shoulder * y / (1 - y);  // X^(1/gamma)
        r.inverse[std::size_t(z)] = std::pow(root, gamma);
    }
    return r;
}

double Response::forward(double exposure) const {
    if (!(exposure > 0)) return 0;
    const double root = std::pow(exposure, 1 / gamma);
    return std::min(255.0, 255.0 * (1 + shoulder) * root / (root + shoulder));
}

double code_weight(int z) {
    if (z <= 0 || z >= 255) return 0;
    const double t = (z - 127.5) / 127.5;
    return std::exp(-4 * t * t) - std::exp(-4.0);
}

}  // namespace glint::capture
