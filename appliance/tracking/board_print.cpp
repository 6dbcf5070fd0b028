#include "appliance/tracking/board_print.hpp"

#include <cmath>
#include <opencv2/aruco.hpp>

#include "appliance/core/errors.hpp"

namespace glint::tracking {

cv::Point2d board_to_print(const Board& board, double px_per_mm, double x_m, double y_m) {
    return {(x_m * 1000 + board.width_m() * 500) * px_per_mm, (board.height_m() * 500 - y_m * 1000) * px_per_mm};
}

cv::Mat draw_board(const Board& board, double px_per_mm) {
    if (!(px_per_mm > 0) || px_per_mm > 100) throw InputError("--px-per-mm must be in (0, 100]");
    const double w = std::round(board.width_m() * 1000 * px_per_mm), h = std::round(board.height_m() * 1000 * px_per_mm);
    if (w > 30000 || h > 30000) throw InputError("--px-per-mm: the board would be larger than 30000 pixels");
    cv::Mat image(int(h), int(w), CV_8UC1, cv::Scalar(255));
    const int side = int(std::lround(board.spec().marker_mm * px_per_mm));
    if (side < 6) throw InputError("--px-per-mm: markers would be smaller than 6 pixels");
    for (int i = 0; i < board.marker_count(); ++i) {
        const cv::Point3f tl = board.corners(i)[0];
        const cv::Point2d p = board_to_print(board, px_per_mm, tl.x, tl.y);
        cv::Mat marker;
        cv::aruco::drawMarker(board.dictionary(), board.first_id() + i, side, marker, 1);
        marker.copyTo(image(cv::Rect(int(std::lround(p.x)), int(std::lround(p.y)), side, side)));
    }
    return image;
}

}  // namespace glint::tracking
