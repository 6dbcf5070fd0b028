// The board: geometry and frame convention, the printed image, the board file's errors.
#include <gtest/gtest.h>

#include <opencv2/aruco.hpp>

#include "appliance/core/errors.hpp"
#include "appliance/tracking/board.hpp"
#include "appliance/tracking/board_print.hpp"

namespace glint::tracking {
namespace {

TEST(TrackingBoard, DefaultGeometryAndFrame) {
    const Board b;
    EXPECT_EQ(b.marker_count(), 35);
    EXPECT_NEAR(b.width_m(), 0.280, 1e-9);
    EXPECT_NEAR(b.height_m(), 0.380, 1e-9);
    // Marker 0 is the top-left one: +X right, +Y up, origin at the centre.
    const auto& m0 = b.corners(0);
    EXPECT_NEAR(m0[0].x, -0.120, 1e-6);
    EXPECT_NEAR(m0[0].y, 0.170, 1e-6);
    EXPECT_NEAR(m0[1].x - m0[0].x, 0.040, 1e-6);  // top-right is to the right
    EXPECT_NEAR(m0[3].y - m0[0].y, -0.040, 1e-6); // bottom-left is below
    const auto& last = b.corners(34);
    EXPECT_NEAR(last[2].x, 0.120, 1e-6);
    EXPECT_NEAR(last[2].y, -0.170, 1e-6);
    // Corners go clockwise as printed (seen from +Z): the signed area with +Y up is negative.
    double area = 0;
    for (int i = 0; i < 4; ++i) area += m0[i].x * m0[(i + 1) % 4].y - m0[(i + 1) % 4].x * m0[i].y;
    EXPECT_LT(area, 0);
    EXPECT_EQ(b.index_of(34), 34);
    EXPECT_EQ(b.index_of(35), -1);
}

TEST(TrackingBoard, PrintedImageHasMarkersWhereTheFrameSays) {
    const Board b;
    const cv::Mat print = draw_board(b, 2.0);
    ASSERT_EQ(print.cols, 560);
    ASSERT_EQ(print.rows, 760);
    // Margin white; marker 0's top-left pixel (20 mm in = 40 px) black, the one before it white.
    EXPECT_EQ(print.at<std::uint8_t>(5, 5), 255);
    EXPECT_EQ(print.at<std::uint8_t>(40, 40), 0);
    EXPECT_EQ(print.at<std::uint8_t>(39, 39), 255);
    const cv::Point2d p = board_to_print(b, 2.0, 0, 0);
    EXPECT_NEAR(p.x, 280, 1e-9);
    EXPECT_NEAR(p.y, 380, 1e-9);
    // ArUco reads every marker, and marker i's corners land where board_to_print puts them.
    std::vector<std::vector<cv::Point2f>> corners;
    std::vector<int> ids;
    cv::Mat padded;
    cv::copyMakeBorder(print, padded, 20, 20, 20, 20, cv::BORDER_CONSTANT, cv::Scalar(255));
    cv::aruco::detectMarkers(padded, b.dictionary(), corners, ids);
    ASSERT_EQ(ids.size(), 35u);
    for (std::size_t i = 0; i < ids.size(); ++i) {
        const cv::Point3f c0 = b.corners(b.index_of(ids[i]))[0];
        const cv::Point2d expected = board_to_print(b, 2.0, c0.x, c0.y) + cv::Point2d(20, 20);
        EXPECT_NEAR(corners[i][0].x, expected.x, 1.5) << "marker " << ids[i];
        EXPECT_NEAR(corners[i][0].y, expected.y, 1.5) << "marker " << ids[i];
    }
}

TEST(TrackingBoard, BoardFileErrorsNameTheKey) {
    const BoardSpec s = board_spec_from_json(R"({"columns": 4, "rows": 6, "marker_mm": 30, "dictionary": "DICT_5X5_100"})",
                                             "b.json");
    EXPECT_EQ(s.columns, 4);
    EXPECT_EQ(s.rows, 6);
    EXPECT_DOUBLE_EQ(s.marker_mm, 30);
    EXPECT_EQ(s.dictionary, "DICT_5X5_100");
    const auto message = [](const std::string& text) {
        try {
            board_spec_from_json(text, "b.json");
        } catch (const InputError& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(message(R"({"colums": 4})").find("b.json: key 'colums': unknown key"), std::string::npos);
    EXPECT_NE(message(R"({"rows": 2.5})").find("key 'rows': must be a whole number"), std::string::npos);
    EXPECT_NE(message(R"({"marker_mm": -1})").find("key 'marker_mm'"), std::string::npos);
    EXPECT_NE(message(R"({"dictionary": "DICT_9X9"})").find("key 'dictionary': unknown dictionary"), std::string::npos);
    // A number beyond double's range: nlohmann throws out_of_range, not parse_error.
    EXPECT_NE(message(R"({"marker_mm": 1e999})").find("b.json: not JSON"), std::string::npos);
    EXPECT_NE(message(R"({"columns": 10, "rows": 10})").find("exceed DICT_4X4_50"), std::string::npos);
    EXPECT_NE(message("[1, 2]").find("must be a JSON object"), std::string::npos);
    EXPECT_NE(message("{").find("b.json: not JSON"), std::string::npos);
    EXPECT_THROW(load_board_spec("/nonexistent/board.json"), InputError);
}

}  // namespace
}  // namespace glint::tracking
