#include "appliance/capture/charuco.hpp"

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "appliance/core/errors.hpp"

namespace glint::capture {

cv::Ptr<cv::aruco::CharucoBoard> make_charuco_board(const CharucoSpec& s) {
    return cv::aruco::CharucoBoard::create(s.squares_x, s.squares_y, float(s.square_m), float(s.marker_m),
                                           cv::aruco::getPredefinedDictionary(s.dictionary));
}

cv::Mat render_charuco_view(const CharucoSpec& spec, const Intrinsics& k, const cv::Matx33d& R, const cv::Vec3d& t) {
    const double width_m = spec.squares_x * spec.square_m, height_m = spec.squares_y * spec.square_m;
    const int px_per_square = 80;
    cv::Mat board;
    make_charuco_board(spec)->draw(cv::Size(spec.squares_x * px_per_square, spec.squares_y * px_per_square), board, 0, 1);
    const cv::Vec3d n = R * cv::Vec3d(0, 0, 1);
    cv::Mat out(k.height, k.width, CV_8UC3);
    for (int v = 0; v < k.height; ++v)
        for (int u = 0; u < k.width; ++u) {
            double acc = 0;
            for (int sy = 0; sy < 2; ++sy)
                for (int sx = 0; sx < 2; ++sx) {
                    const glm::dvec3 r = pixel_ray(k, u - 0.25 + 0.5 * sx, v - 0.25 + 0.5 * sy);
                    const cv::Vec3d d(r.x, -r.y, -r.z);  // conventions' camera axes -> OpenCV's
                    double value = 128;
                    const double denom = n.dot(d);
                    if (std::abs(denom) > 1e-9) {
                        const double lambda = n.dot(t) / denom;
                        if (lambda > 0) {
                            const cv::Vec3d local = R.t() * (lambda * d - t);  // board metres
                            if (local[0] >= 0 && local[1] >= 0 && local[0] < width_m && local[1] < height_m) {
                                const int bx = std::min(board.cols - 1, int(local[0] / width_m * board.cols));
                                const int by = std::min(board.rows - 1, int(local[1] / height_m * board.rows));
                                value = 20 + 0.8 * board.at<std::uint8_t>(by, bx);  // printed black is not 0
                            }
                        }
                    }
                    acc += value;
                }
            const auto c = static_cast<std::uint8_t>(std::lround(acc / 4));
            out.at<cv::Vec3b>(v, u) = cv::Vec3b(c, c, c);
        }
    return out;
}

IntrinsicsResult calibrate_intrinsics(const Session& s, const CharucoSpec& spec) {
    const cv::Ptr<cv::aruco::CharucoBoard> board = make_charuco_board(spec);
    std::vector<cv::Mat> all_corners, all_ids;
    cv::Size size;
    IntrinsicsResult out;
    for (const FrameRecord& r : s.frames) {
        const CameraFrame f = load_frame(s, r);
        cv::Mat grey;
        cv::cvtColor(f.rgb, grey, cv::COLOR_RGB2GRAY);
        size = grey.size();
        std::vector<std::vector<cv::Point2f>> corners;
        std::vector<int> ids;
        cv::aruco::detectMarkers(grey, board->dictionary, corners, ids);
        if (ids.size() < 4) continue;
        cv::Mat cc, ci;
        const int n = cv::aruco::interpolateCornersCharuco(corners, ids, grey, board, cc, ci);
        if (n < 6) continue;
        all_corners.push_back(cc);
        all_ids.push_back(ci);
        out.corners += n;
    }
    out.views = int(all_corners.size());
    if (out.views < 4)
        throw InputError(s.dir.string() + ": ChArUco board found in only " + std::to_string(out.views) +
                         " frames (at least 4 views with 6 corners each are needed)");
    cv::Mat K, dist;
    // k3 fixed at 0 (OpenCV's advice for ordinary lenses): with k1 and k2 it only trades against them and
    // runs away in the corners the board views reach least.
    out.rms_px = cv::aruco::calibrateCameraCharuco(all_corners, all_ids, board, size, K, dist, cv::noArray(),
                                                   cv::noArray(), cv::CALIB_FIX_K3);
    Intrinsics& in = out.intrinsics;
    in.width = size.width;
    in.height = size.height;
    in.fx = K.at<double>(0, 0);
    in.fy = K.at<double>(1, 1);
    in.cx = K.at<double>(0, 2);
    in.cy = K.at<double>(1, 2);
    const double* d = dist.ptr<double>();
    in.k1 = d[0];
    in.k2 = d[1];
    in.p1 = d[2];
    in.p2 = d[3];
    in.k3 = dist.total() > 4 ? d[4] : 0;
    return out;
}

}  // namespace glint::capture
