#include "appliance/tracking/board_view.hpp"

#include <cmath>
#include <numbers>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "appliance/tracking/board_print.hpp"

namespace glint::tracking {
namespace {

constexpr float kWhite = 0.85f, kBlack = 0.05f, kTable = 0.30f, kSkin = 0.55f;

// A hand lying on the sheet (texture pixels): a palm ellipse and four fingers, scaled so that it
// covers about `fraction` of the board, entering from one edge of the sheet.
void draw_hand(cv::Mat& texture, double fraction, std::mt19937_64& rng) {
    const double area = fraction * texture.rows * texture.cols;
    // Palm ellipse a x b with a = 1.2 b, fingers add about 45 % of the palm's area.
    const double b = std::sqrt(area / (1.45 * std::numbers::pi * 1.2));
    const double a = 1.2 * b;
    std::uniform_real_distribution<double> u(0, 1);
    const int edge = int(rng() % 4);
    const double along = 0.2 + 0.6 * u(rng);
    cv::Point2d centre;
    double angle;  // direction of the fingers, radians
    const double w = texture.cols, h = texture.rows;
    switch (edge) {
    case 0: centre = {along * w, h - 0.6 * a}; angle = -std::numbers::pi / 2; break;  // from the bottom
    case 1: centre = {along * w, 0.6 * a}; angle = std::numbers::pi / 2; break;       // from the top
    case 2: centre = {0.6 * a, along * h}; angle = 0; break;                            // from the left
    default: centre = {w - 0.6 * a, along * h}; angle = std::numbers::pi; break;        // from the right
    }
    angle += (u(rng) - 0.5) * 0.6;
    const cv::Scalar skin(kSkin);
    cv::ellipse(texture, cv::Point(centre), cv::Size(int(a), int(b)), angle * 180 / std::numbers::pi, 0, 360, skin,
                cv::FILLED, cv::LINE_AA);
    const cv::Point2d dir(std::cos(angle), std::sin(angle)), side(-dir.y, dir.x);
    for (int f = 0; f < 4; ++f) {
        const double offset = (f - 1.5) * 0.5 * b, length = (f == 0 || f == 3 ? 1.0 : 1.3) * a;
        const cv::Point2d base = centre + dir * (0.7 * a) + side * offset;
        const cv::Point2d tip = base + dir * length;
        cv::line(texture, cv::Point(base), cv::Point(tip), skin, std::max(2, int(0.38 * b)), cv::LINE_AA);
    }
}

}  // namespace

BoardRenderer::BoardRenderer(const Board& board, const Camera& camera, int supersample, double texture_px_per_mm)
    : BoardRenderer(board, camera, draw_board(board, texture_px_per_mm), texture_px_per_mm, supersample) {}

BoardRenderer::BoardRenderer(const Board& board, const Camera& camera, const cv::Mat& print, double print_px_per_mm,
                             int supersample)
    : board_(board), camera_(camera), supersample_(supersample), texture_px_per_mm_(print_px_per_mm) {
    print.convertTo(texture_, CV_32F, (kWhite - kBlack) / 255.0, kBlack);
    // The undistorted normalised coordinates of every sub-pixel centre, once per camera.
    const int sw = camera.width * supersample, sh = camera.height * supersample;
    std::vector<cv::Point2f> pixels;
    pixels.reserve(std::size_t(sw) * sh);
    for (int y = 0; y < sh; ++y)
        for (int x = 0; x < sw; ++x)
            pixels.emplace_back(float((x + 0.5) / supersample - 0.5), float((y + 0.5) / supersample - 0.5));
    std::vector<cv::Point2f> normalised;
    cv::undistortPoints(pixels, normalised, camera.matrix(), camera.distortion(), cv::noArray(), cv::noArray(),
                        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 1e-10));
    ray_x_.create(sh, sw, CV_32F);
    ray_y_.create(sh, sw, CV_32F);
    for (int y = 0; y < sh; ++y)
        for (int x = 0; x < sw; ++x) {
            ray_x_.at<float>(y, x) = normalised[std::size_t(y) * sw + x].x;
            ray_y_.at<float>(y, x) = normalised[std::size_t(y) * sw + x].y;
        }
}

cv::Mat BoardRenderer::render(const Pose& camera_from_board, const ViewConditions& c, std::uint64_t seed) const {
    std::mt19937_64 rng(seed);
    cv::Mat texture = texture_;
    if (c.hand_fraction > 0) {
        texture = texture_.clone();
        draw_hand(texture, c.hand_fraction, rng);
    }
    // Ray d = (x, y, 1) in the camera; in the board frame o + s M d with M = R^T, o = -R^T t; the
    // plane z = 0 is met at s = -o.z / (M d).z.
    const Pose board_from_camera = camera_from_board.inverse();
    const glm::dmat3 m = glm::mat3_cast(board_from_camera.rotation);  // m[col][row]
    const glm::dvec3 o = board_from_camera.translation;
    const double k = texture_px_per_mm_ * 1000, half_w = board_.width_m() / 2, half_h = board_.height_m() / 2;
    cv::Mat map_x(ray_x_.size(), CV_32F), map_y(ray_x_.size(), CV_32F);
    for (int y = 0; y < ray_x_.rows; ++y) {
        const float* rx = ray_x_.ptr<float>(y);
        const float* ry = ray_y_.ptr<float>(y);
        float* mx = map_x.ptr<float>(y);
        float* my = map_y.ptr<float>(y);
        for (int x = 0; x < ray_x_.cols; ++x) {
            const double dx = rx[x], dy = ry[x];
            const double ax = m[0][0] * dx + m[1][0] * dy + m[2][0];
            const double ay = m[0][1] * dx + m[1][1] * dy + m[2][1];
            const double az = m[0][2] * dx + m[1][2] * dy + m[2][2];
            const double s = -o.z / az;
            if (!(s > 0)) {
                mx[x] = my[x] = -1e6f;
                continue;
            }
            // Print pixel-edge coordinates, then remap's centre-at-integer convention.
            mx[x] = float((o.x + s * ax + half_w) * k - 0.5);
            my[x] = float((half_h - (o.y + s * ay)) * k - 0.5);
        }
    }
    cv::Mat fine;
    cv::remap(texture, fine, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(kTable));
    cv::Mat image;
    cv::resize(fine, image, cv::Size(camera_.width, camera_.height), 0, 0, cv::INTER_AREA);
    // Exposure: white paper (0.85) at ~212 codes when light = 1.
    image *= 250.0 * c.light;
    std::uniform_real_distribution<double> u(0, 1);
    if (c.glare > 0) {
        // A soft veil of scattered light centred somewhere on the board's image.
        const glm::dvec3 centre = camera_from_board.apply({(u(rng) - 0.5) * board_.width_m() * 0.6,
                                                           (u(rng) - 0.5) * board_.height_m() * 0.6, 0});
        const double px = camera_.fx * centre.x / centre.z + camera_.cx, py = camera_.fy * centre.y / centre.z + camera_.cy;
        const double sigma = 0.12 * camera_.width;
        for (int y = 0; y < image.rows; ++y) {
            float* row = image.ptr<float>(y);
            for (int x = 0; x < image.cols; ++x) {
                const double r2 = (x - px) * (x - px) + (y - py) * (y - py);
                row[x] += float(255 * c.glare * std::exp(-0.5 * r2 / (sigma * sigma)));
            }
        }
    }
    if (c.blur_px > 0) cv::GaussianBlur(image, image, cv::Size(0, 0), c.blur_px);
    if (c.noise > 0) {
        // Read noise plus shot noise: sigma^2 = (noise^2 / 2) (1 + level / 128).
        std::normal_distribution<float> n(0, 1);
        for (int y = 0; y < image.rows; ++y) {
            float* row = image.ptr<float>(y);
            for (int x = 0; x < image.cols; ++x)
                row[x] += float(c.noise * std::sqrt(0.5 * (1 + std::max(0.0f, row[x]) / 128.0))) * n(rng);
        }
    }
    cv::Mat out;
    image.convertTo(out, CV_8U);  // rounds and saturates
    return out;
}

}  // namespace glint::tracking
