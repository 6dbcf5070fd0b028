#include "appliance/tracking/edge_refine.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <vector>

namespace glint::tracking {
namespace {

// Bilinear sample of an 8-bit image at pixel-centre coordinates; -1 outside.
inline double sample(const cv::Mat& g, double x, double y) {
    if (x < 0 || y < 0 || x > g.cols - 1.001 || y > g.rows - 1.001) return -1;
    const int x0 = int(x), y0 = int(y);
    const double fx = x - x0, fy = y - y0;
    const std::uint8_t* r0 = g.ptr<std::uint8_t>(y0) + x0;
    const std::uint8_t* r1 = r0 + g.step[0];
    return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
}

struct Line {
    cv::Point2d point, dir;  // through `point` along unit `dir`
};

// Weighted total least squares line; false when degenerate.
bool fit_line(const std::vector<cv::Point2d>& p, const std::vector<double>& w, Line& line) {
    double sw = 0, mx = 0, my = 0;
    for (std::size_t i = 0; i < p.size(); ++i) sw += w[i], mx += w[i] * p[i].x, my += w[i] * p[i].y;
    if (!(sw > 0)) return false;
    mx /= sw, my /= sw;
    double sxx = 0, sxy = 0, syy = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
        const double dx = p[i].x - mx, dy = p[i].y - my;
        sxx += w[i] * dx * dx, sxy += w[i] * dx * dy, syy += w[i] * dy * dy;
    }
    const double angle = 0.5 * std::atan2(2 * sxy, sxx - syy);  // direction of largest spread
    line = {{mx, my}, {std::cos(angle), std::sin(angle)}};
    return true;
}

bool intersect(const Line& a, const Line& b, cv::Point2d& out) {
    const double det = a.dir.x * (-b.dir.y) - a.dir.y * (-b.dir.x);
    if (std::abs(det) < 1e-6) return false;
    const cv::Point2d d = b.point - a.point;
    const double s = (d.x * (-b.dir.y) - d.y * (-b.dir.x)) / det;
    out = a.point + a.dir * s;
    return true;
}

}  // namespace

std::vector<cv::Point2d> undistort_pixels(const Camera& camera, const std::vector<cv::Point2d>& pixels) {
    if (!camera.distorted() || pixels.empty()) return pixels;
    std::vector<cv::Point2d> out;
    cv::undistortPoints(pixels, out, camera.matrix(), camera.distortion(), cv::noArray(), camera.matrix(),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 1e-9));
    return out;
}

bool refine_marker_corners(const cv::Mat& gray, const Camera& camera, const std::array<cv::Point2f, 4>& initial,
                           std::array<cv::Point2d, 4>& undistorted) {
    const cv::Point2d centre = 0.25 * (cv::Point2d(initial[0]) + cv::Point2d(initial[1]) + cv::Point2d(initial[2]) +
                                       cv::Point2d(initial[3]));
    std::array<Line, 4> lines;
    for (int e = 0; e < 4; ++e) {
        const cv::Point2d a = initial[e], b = initial[(e + 1) % 4];
        const double length = cv::norm(b - a);
        if (length < 4) return false;
        const cv::Point2d dir = (b - a) / length;
        cv::Point2d out(-dir.y, dir.x);  // normal pointing away from the marker's centre
        if ((a - centre).dot(out) < 0) out = -out;
        // Search across the edge by less than the black border's width (1/6 of the side for
        // 4x4 markers), so the inner cells' edges (of the opposite sign anyway) stay out of reach.
        const double reach = std::clamp(0.14 * length, 1.5, 5.0), step = 0.5;
        const int half = int(reach / step) + 1;
        const int samples = std::clamp(int(length / 1.5), 6, 40);
        std::vector<cv::Point2d> points;
        std::vector<double> weights;
        std::vector<double> profile(2 * half + 3);
        for (int s = 0; s < samples; ++s) {
            // Stay clear of the corners, where the neighbouring edge bends the profile.
            const double t = 0.12 + 0.76 * (s + 0.5) / samples;
            const cv::Point2d base = a + (b - a) * t;
            bool inside = true;
            for (int k = -half - 1; k <= half + 1 && inside; ++k) {
                const cv::Point2d q = base + out * (k * step);
                profile[k + half + 1] = sample(gray, q.x, q.y);
                inside = profile[k + half + 1] >= 0;
            }
            if (!inside) continue;
            // Derivative outwards (dark inside -> bright outside is positive); its maximum.
            int best = -1;
            double best_d = 0;
            std::vector<double> d(2 * half + 1);
            for (int k = -half; k <= half; ++k) {
                d[k + half] = (profile[k + half + 2] - profile[k + half]) / (2 * step);
                if (d[k + half] > best_d) best_d = d[k + half], best = k + half;
            }
            if (best <= 0 || best >= 2 * half || best_d < 4) continue;  // at the search's end, or no edge
            const double dm = d[best - 1], d0 = d[best], dp = d[best + 1];
            const double denom = dm - 2 * d0 + dp;
            const double frac = denom < 0 ? std::clamp(0.5 * (dm - dp) / denom, -0.5, 0.5) : 0.0;
            points.push_back(base + out * ((best - half + frac) * step));
            weights.push_back(best_d);
        }
        if (points.size() < 4) return false;
        points = undistort_pixels(camera, points);
        if (!fit_line(points, weights, lines[e])) return false;
        // One pass against outliers (a hand's edge, a glare step): drop points far off the line.
        std::vector<double> residual(points.size());
        for (std::size_t i = 0; i < points.size(); ++i) {
            const cv::Point2d d = points[i] - lines[e].point;
            residual[i] = std::abs(d.x * -lines[e].dir.y + d.y * lines[e].dir.x);
        }
        std::vector<double> sorted = residual;
        std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
        const double limit = std::max(0.3, 3 * 1.4826 * sorted[sorted.size() / 2]);
        std::vector<cv::Point2d> kept;
        std::vector<double> kept_w;
        for (std::size_t i = 0; i < points.size(); ++i)
            if (residual[i] <= limit) kept.push_back(points[i]), kept_w.push_back(weights[i]);
        if (kept.size() < 4) return false;
        if (!fit_line(kept, kept_w, lines[e])) return false;
    }
    // Corner i joins edge i-1 (ending at it) and edge i (starting at it).
    for (int i = 0; i < 4; ++i)
        if (!intersect(lines[(i + 3) % 4], lines[i], undistorted[i])) return false;
    // The refined corners must stay near the detected ones: a corner that moved by more than a
    // quarter of the side is a bad fit. (The detector's own corners can be 3 px off on blurred,
    // dark frames: its thresholded outline shrinks or grows with the blur.)
    const std::vector<cv::Point2d> initial_u =
        undistort_pixels(camera, {initial[0], initial[1], initial[2], initial[3]});
    double side = 1e9;
    for (int i = 0; i < 4; ++i) side = std::min(side, cv::norm(initial_u[(i + 1) % 4] - initial_u[i]));
    for (int i = 0; i < 4; ++i)
        if (cv::norm(undistorted[i] - initial_u[i]) > std::max(2.0, 0.25 * side)) return false;
    return true;
}

}  // namespace glint::tracking
