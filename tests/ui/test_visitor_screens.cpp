// The visitor screens drawn at 1280x720 over a stand-in frame and read back: the texts are where
// they belong, the progress bars fill as far as the progress, the arrow points at the target, the
// minimap shows the covered half brighter, the AR screen leaves the centre alone.
#include <gtest/gtest.h>

#include <GLES3/gl3.h>

#include <algorithm>
#include <cmath>

#include "appliance/core/errors.hpp"
#include "appliance/ui/screens.hpp"
#include "tests/ui/ui_fixture.hpp"

using namespace glint;
using namespace glint::test;
using glint::ui::KioskState;
using glint::ui::ScreenModel;

namespace {

const Rgb kWhite{255, 255, 255};
const Rgb kAmber = rgb_of(ui::colours::kAccent);
const Rgb kGreen = rgb_of(ui::colours::kProgress);
const Rgb kTrack = rgb_of(ui::colours::kTrack);

gl::RgbImage screen(const ScreenModel& model, const std::string& name = "") {
    return UiTest::frame([&] { ui::draw_visitor_screen(model, UiTest::strings(), kWidth, kHeight); }, name);
}

ScreenModel capture_model() {
    ScreenModel m;
    m.state = KioskState::Capture;
    m.t_s = 12.0;
    m.capture.target_x = 0.8;
    m.capture.target_y = -0.2;
    m.capture.target_z = 0.57;
    m.capture.turn_deg = 55;
    m.capture.progress = 0.42;
    m.capture.time_left_s = 38;
    m.capture.exposure = "ok";
    // Coverage: the band around the horizon in front and a patch to the left.
    m.capture.minimap_width = 64;
    m.capture.minimap_height = 32;
    m.capture.minimap.assign(64 * 32, 0);
    for (int j = 10; j < 22; ++j)
        for (int i = 8; i < 40; ++i) m.capture.minimap[std::size_t(j) * 64 + std::size_t(i)] = std::uint8_t(i < 20 ? 150 : 255);
    m.capture.view_x = 0.5;
    m.capture.view_y = 0.1;
    m.capture.view_z = -0.86;
    return m;
}

// The row of the bar in the bottom part of the image (most pixels of the filled colour) and, on
// that row, the filled and unfilled lengths.
struct Bar {
    int row = -1, filled = 0, track = 0;
};
Bar measure_bar(const gl::RgbImage& image, int y0, int y1) {
    Bar best;
    for (int y = y0; y < y1; ++y) {
        Bar b{y, count(image, kGreen, 0, y, kWidth, y + 1, 2), count(image, kTrack, 0, y, kWidth, y + 1, 2)};
        if (b.filled + b.track > best.filled + best.track) best = b;
    }
    return best;
}

// The centroid of the amber pixels within `radius` of the frame's centre.
std::pair<double, double> amber_centroid(const gl::RgbImage& image, int radius) {
    double sx = 0, sy = 0, n = 0;
    for (int y = kHeight / 2 - radius; y < kHeight / 2 + radius; ++y)
        for (int x = kWidth / 2 - radius; x < kWidth / 2 + radius; ++x)
            if (near(pixel(image, x, y), kAmber, 4)) {
                sx += x;
                sy += y;
                n += 1;
            }
    EXPECT_GT(n, 2000) << "no arrow";
    return {sx / std::max(n, 1.0) - kWidth / 2.0, sy / std::max(n, 1.0) - kHeight / 2.0};
}

// x extent of the white pixels in a band of rows.
int white_width(const gl::RgbImage& image, int y0, int y1) {
    int lo = kWidth, hi = -1;
    for (int y = y0; y < y1; ++y)
        for (int x = 0; x < kWidth; ++x)
            if (near(pixel(image, x, y), kWhite, 2)) {
                lo = std::min(lo, x);
                hi = std::max(hi, x);
            }
    return hi - lo;
}

}  // namespace

class VisitorScreens : public UiTest {};

TEST_F(VisitorScreens, AttractCallsToPressTheButtonAndBreathes) {
    ScreenModel m;
    m.state = KioskState::Attract;
    m.t_s = 0.75;  // a quarter of the 3 s breath: the largest
    const gl::RgbImage big = screen(m, "attract");
    // The call and the subtitle: white text in the lower middle, nothing white in the top third
    // (the stand-in frame has no white).
    EXPECT_GT(count(big, kWhite, kWidth / 10, kHeight / 2, kWidth * 9 / 10, kHeight * 19 / 20, 2), 3000);
    EXPECT_EQ(count(big, kWhite, 0, 0, kWidth, kHeight / 3, 2), 0);
    // The button: amber around (W/2, 0.4 H).
    EXPECT_GT(count(big, kAmber, kWidth / 2 - 40, kHeight * 2 / 5 - 40, kWidth / 2 + 40, kHeight * 2 / 5 + 40, 2), 3000);
    m.t_s = 2.25;  // three quarters: the smallest
    const gl::RgbImage small = screen(m);
    const int title_top = kHeight * 54 / 100, title_bottom = title_top + 80;
    EXPECT_GT(white_width(big, title_top, title_bottom), white_width(small, title_top, title_bottom) + 20);
}

TEST_F(VisitorScreens, CaptureShowsItsPartsAndSavesAScreenshot) {
    ScreenModel m = capture_model();
    m.capture.too_fast = true;
    m.capture.exposure = "too_bright";
    const gl::RgbImage image = screen(m, "capture");
    // Title at the top, "slower" (amber, large) beneath it, exposure words at the top left.
    EXPECT_GT(count(image, kWhite, kWidth / 4, 0, kWidth * 3 / 4, kHeight / 10, 2), 500);
    EXPECT_GT(count(image, kAmber, kWidth / 5, kHeight / 7, kWidth * 4 / 5, kHeight / 3, 2), 1500);
    EXPECT_GT(count(image, kWhite, 0, 0, kWidth / 4, kHeight / 10, 2), 200);
    EXPECT_GT(count(image, kAmber, 0, 0, kWidth / 20, kHeight / 10, 2), 50);  // the exposure dot is amber
    // Progress words and time left above the bar.
    EXPECT_GT(count(image, kWhite, 0, kHeight * 3 / 4, kWidth / 2, kHeight, 2), 150);
}

TEST_F(VisitorScreens, CaptureProgressBarFillsAsFarAsTheProgress) {
    ScreenModel m = capture_model();
    m.capture.progress = 0.25;
    const Bar quarter = measure_bar(screen(m), kHeight * 3 / 4, kHeight);
    m.capture.progress = 0.75;
    const Bar three = measure_bar(screen(m), kHeight * 3 / 4, kHeight);
    ASSERT_GT(quarter.filled + quarter.track, kWidth / 3) << "no bar found";
    const double length = quarter.filled + quarter.track;
    EXPECT_NEAR(three.filled + three.track, length, 1);
    EXPECT_NEAR(quarter.filled / length, 0.25, 0.01);
    EXPECT_NEAR(three.filled / length, 0.75, 0.01);
}

TEST_F(VisitorScreens, ArrowPointsTowardsTheTarget) {
    ScreenModel m = capture_model();
    m.capture.target_x = -0.8, m.capture.target_y = 0, m.capture.target_z = 0.6;
    const auto left = amber_centroid(screen(m), kHeight / 3);
    m.capture.target_x = 0.8;
    const auto right = amber_centroid(screen(m), kHeight / 3);
    m.capture.target_x = 0, m.capture.target_y = -0.9, m.capture.target_z = 0.44;  // up (camera +Y is down)
    const auto up = amber_centroid(screen(m), kHeight / 3);
    EXPECT_LT(left.first, -kHeight * 0.1);
    EXPECT_NEAR(left.second, 0, 5);
    EXPECT_GT(right.first, kHeight * 0.1);
    EXPECT_NEAR(right.second, 0, 5);
    EXPECT_LT(up.second, -kHeight * 0.1);
    EXPECT_NEAR(up.first, 0, 5);
    // On target: no arrow, a green ring.
    m.capture.on_target = true;
    const gl::RgbImage hold = screen(m);
    EXPECT_LT(count(hold, kAmber, kWidth / 2 - 200, kHeight / 2 - 200, kWidth / 2 + 200, kHeight / 2 + 200, 4), 50);
    EXPECT_GT(count(hold, kGreen, kWidth / 2 - 100, kHeight / 2 - 100, kWidth / 2 + 100, kHeight / 2 + 100, 4), 1000);
}

TEST_F(VisitorScreens, MinimapShowsCoveredCellsBrighterThanUnseenOnes) {
    // Where the discs are: the pixels that change between no coverage and full coverage.
    ScreenModel m = capture_model();
    m.capture.view_x = 0, m.capture.view_y = 1, m.capture.view_z = 0;  // mark at the discs' rim tops
    std::fill(m.capture.minimap.begin(), m.capture.minimap.end(), std::uint8_t(0));
    const gl::RgbImage none = screen(m);
    std::fill(m.capture.minimap.begin(), m.capture.minimap.end(), std::uint8_t(255));
    const gl::RgbImage all = screen(m);
    int x0 = kWidth, x1 = 0, y0 = kHeight, y1 = 0;
    for (int y = 0; y < kHeight; ++y)
        for (int x = 0; x < kWidth; ++x)
            if (!near(pixel(none, x, y), pixel(all, x, y), 10)) {
                x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
            }
    ASSERT_LT(x0, x1) << "the minimap does not change with coverage";
    EXPECT_GT(x0, kWidth / 2);  // bottom right
    EXPECT_GT(y0, kHeight / 2);
    // Two discs side by side: the front one (looking at -Z, +X to the right) on the left, the back
    // one (looking at +Z, -X to the right) on the right.
    const int mid = (x0 + x1) / 2, cy = (y0 + y1) / 2, r = (y1 - y0) / 2;
    const int front_cx = (x0 + mid) / 2, back_cx = (mid + x1) / 2;
    // The left half of the sphere (x < 0: equirect columns u < 0.5) covered.
    for (int j = 0; j < m.capture.minimap_height; ++j)
        for (int i = 0; i < m.capture.minimap_width; ++i)
            m.capture.minimap[std::size_t(j) * 64 + std::size_t(i)] = i < m.capture.minimap_width / 2 ? 255 : 0;
    const gl::RgbImage half = screen(m);
    const auto mean = [&](int cx, int side) {  // the disc's left (-1) or right (+1) half, off the middle
        double sum = 0;
        int n = 0;
        for (int y = cy - r / 2; y < cy + r / 2; ++y)
            for (int x = cx + side * r / 4; x != cx + side * r * 3 / 4; x += side) {
                sum += luminance(pixel(half, x, y));
                ++n;
            }
        return sum / n;
    };
    EXPECT_GT(mean(front_cx, -1), mean(front_cx, +1) + 60);  // front: -X on the left
    EXPECT_GT(mean(back_cx, +1), mean(back_cx, -1) + 60);    // back: -X on the right
}

TEST_F(VisitorScreens, MinimapCellFollowsTheEquirectConvention) {
    ui::CaptureView v;
    v.minimap_width = 8;
    v.minimap_height = 4;
    v.minimap.resize(32);
    for (std::size_t k = 0; k < 32; ++k) v.minimap[k] = std::uint8_t(k);
    // docs/conventions.md: -Z at the map's centre (u = 0.5), -X at u = 0.25, +Y the top row.
    EXPECT_EQ(ui::minimap_cell(v, 0.001, 0.001, -1), 1 * 8 + 4);  // just right of the centre, just above the equator
    EXPECT_EQ(ui::minimap_cell(v, -1, -0.001, 0), 2 * 8 + 2);  // left, just below the equator
    EXPECT_EQ(ui::minimap_cell(v, 0, 1, 0) / 8, 0);
    EXPECT_EQ(ui::minimap_cell(v, 0, -1, 0) / 8, 3);
    v.minimap.clear();
    EXPECT_EQ(ui::minimap_cell(v, 0, 0, -1), 0);  // no map: nothing covered
}

TEST_F(VisitorScreens, ProcessingShowsStepBarAndTimeLeft) {
    ScreenModel m;
    m.state = KioskState::Processing;
    m.processing.step = "processing.convolving";
    m.processing.progress = 0.25;
    m.processing.time_left_s = 4.2;
    const gl::RgbImage quarter_image = screen(m, "processing");
    EXPECT_GT(count(quarter_image, kWhite, kWidth / 5, kHeight / 2, kWidth * 4 / 5, kHeight, 2), 2000);
    EXPECT_EQ(count(quarter_image, kWhite, 0, 0, kWidth, kHeight / 2, 2), 0);  // the maps above stay visible
    const Bar quarter = measure_bar(quarter_image, kHeight / 2, kHeight);
    m.processing.progress = 0.75;
    const Bar three = measure_bar(screen(m), kHeight / 2, kHeight);
    const double length = quarter.filled + quarter.track;
    ASSERT_GT(length, kWidth / 3);
    EXPECT_NEAR(quarter.filled / length, 0.25, 0.01);
    EXPECT_NEAR(three.filled / length, 0.75, 0.01);
    EXPECT_NEAR(three.filled - quarter.filled, 0.5 * length, 2);
}

TEST_F(VisitorScreens, ArKeepsTheCentreClearAndShowsMaterialAndTracking) {
    const gl::RgbImage plain = frame([] {});
    ScreenModel m;
    m.state = KioskState::Ar;
    m.ar.material = "material.glossy";
    m.ar.tracked = true;
    m.ar.visibility = 1;
    const gl::RgbImage image = screen(m, "ar");
    // The middle 60 % x 60 % is the frame itself, pixel for pixel.
    int changed = 0;
    for (int y = kHeight / 5; y < kHeight * 4 / 5; ++y)
        for (int x = kWidth / 5; x < kWidth * 4 / 5; ++x) changed += !near(pixel(image, x, y), pixel(plain, x, y), 0);
    EXPECT_EQ(changed, 0);
    EXPECT_GT(count(image, kWhite, 0, kHeight * 3 / 4, kWidth / 2, kHeight, 2), 800);        // name + hint
    EXPECT_GT(count(image, kGreen, kWidth * 3 / 4, 0, kWidth, kHeight / 8, 2), 100);          // tracking
    m.ar.tracked = false;
    m.ar.bridged = true;
    m.ar.visibility = 1;
    const gl::RgbImage held = screen(m);
    EXPECT_EQ(count(held, kGreen, kWidth * 3 / 4, 0, kWidth, kHeight / 8, 2), 0);
    EXPECT_GT(count(held, kAmber, kWidth * 3 / 4, 0, kWidth, kHeight / 8, 2), 100);
}

TEST_F(VisitorScreens, MessageSensorLostAndDegradedOverAnyState) {
    ScreenModel m = capture_model();
    const gl::RgbImage plain = screen(m);
    m.message = "message.scan_timeout";
    const gl::RgbImage banner = screen(m, "message");
    // The banner replaces the title at the top: more text there, on the banner's blue.
    EXPECT_GT(count(banner, kWhite, 0, 0, kWidth, kHeight / 8, 2), count(plain, kWhite, 0, 0, kWidth, kHeight / 8, 2) + 300);
    EXPECT_GT(count(banner, Rgb{25, 35, 70}, 0, 0, kWidth, kHeight / 8, 12), 3000);

    ScreenModel lost;
    lost.state = KioskState::Ar;
    lost.ar.material = "material.matte";
    lost.sensor_lost = true;
    lost.degraded = true;
    lost.t_s = 3.3;
    const gl::RgbImage image = screen(lost, "sensor_lost");
    EXPECT_GT(count(image, kAmber, kWidth / 5, kHeight * 2 / 5, kWidth * 4 / 5, kHeight * 3 / 5, 2), 500);
    lost.degraded = false;
    const gl::RgbImage clean = screen(lost);
    int mark = 0;
    for (int y = kHeight * 19 / 20; y < kHeight; ++y)
        for (int x = kWidth / 3; x < kWidth * 2 / 3; ++x) mark += !near(pixel(image, x, y), pixel(clean, x, y), 20);
    EXPECT_GT(mark, 100);  // the degraded mark, bottom centre
}

TEST_F(VisitorScreens, UnknownKeysFromTheModelShowAsThemselves) {
    ScreenModel m;
    m.state = KioskState::Ar;
    m.ar.material = "material.velvet";  // a material named in the config without a string
    EXPECT_NO_THROW(screen(m));
    EXPECT_EQ(strings().get("material.velvet"), "material.velvet");
}

TEST_F(VisitorScreens, DrawingOutsideAFrameIsAnError) {
    ScreenModel m;
    EXPECT_THROW(ui::draw_visitor_screen(m, strings(), kWidth, kHeight), RuntimeError);
}
