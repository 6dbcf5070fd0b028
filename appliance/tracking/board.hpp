// The printed board on the exhibit table: a grid of ArUco markers (docs/tracking.md "Board").
//
// Default: 5 columns x 7 rows of 40 mm DICT_4X4_50 markers, 10 mm apart, a 20 mm white margin:
// 280 x 380 mm printed. Marker ids run row by row from the top-left. The board frame: origin at
// the centre of the printed sheet, +X towards its right edge, +Y towards its top edge, +Z out of
// the printed side, metres.
#pragma once

#include <array>
#include <filesystem>
#include <opencv2/aruco.hpp>
#include <string>
#include <vector>

namespace glint::tracking {

struct BoardSpec {
    int columns = 5, rows = 7;
    double marker_mm = 40, gap_mm = 10, margin_mm = 20;
    std::string dictionary = "DICT_4X4_50";
    int first_id = 0;
};

class Board {
public:
    explicit Board(const BoardSpec& spec = {});  // throws InputError for an unusable spec

    const BoardSpec& spec() const { return spec_; }
    double width_m() const;   // the printed sheet, margin included
    double height_m() const;
    int marker_count() const { return spec_.columns * spec_.rows; }
    int first_id() const { return spec_.first_id; }
    // The index of marker `id` on the board, or -1.
    int index_of(int id) const;
    // Corners of the marker with index i in ArUco's order (top-left, top-right, bottom-right,
    // bottom-left as printed), board frame, metres, z = 0.
    const std::array<cv::Point3f, 4>& corners(int index) const { return corners_[index]; }
    const cv::Ptr<cv::aruco::Dictionary>& dictionary() const { return dictionary_; }
    // The same board as OpenCV's aruco::Board (for estimatePoseBoard, the benchmark's anchor).
    cv::Ptr<cv::aruco::Board> aruco_board() const;

private:
    BoardSpec spec_;
    cv::Ptr<cv::aruco::Dictionary> dictionary_;
    std::vector<std::array<cv::Point3f, 4>> corners_;
};

// The board JSON file (`--board FILE`): {"columns": 5, "rows": 7, "marker_mm": 40, "gap_mm": 10,
// "margin_mm": 20, "dictionary": "DICT_4X4_50", "first_id": 0}; every key optional, unknown keys
// rejected. Errors are InputError "SOURCE: key 'k': reason".
BoardSpec board_spec_from_json(const std::string& text, const std::string& source);
BoardSpec load_board_spec(const std::filesystem::path& path);

}  // namespace glint::tracking
