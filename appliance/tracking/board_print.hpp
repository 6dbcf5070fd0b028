// The board as a printable image (`glint track --print-board OUT.png --px-per-mm K`).
#pragma once

#include <opencv2/core.hpp>

#include "appliance/tracking/board.hpp"

namespace glint::tracking {

// The whole sheet, margin included, at `px_per_mm` (8-bit grey, black markers on white). Marker
// edges are rounded to whole pixels; at a whole number of pixels per millimetre they are exact.
// Throws InputError when px_per_mm is not in (0, 100] or the image would exceed 30000 pixels.
cv::Mat draw_board(const Board& board, double px_per_mm);

// Pixel-edge coordinates (0,0 = the top-left corner of the top-left pixel) of a board-frame
// point (metres) in that image.
cv::Point2d board_to_print(const Board& board, double px_per_mm, double x_m, double y_m);

}  // namespace glint::tracking
