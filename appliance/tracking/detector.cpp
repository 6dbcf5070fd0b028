#include "appliance/tracking/detector.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "appliance/core/errors.hpp"
#include "appliance/tracking/edge_refine.hpp"

namespace glint::tracking {
namespace {

using Found = Detector::Found;

// Board markers only, each id once.
void keep_board_markers(const Board& board, Found& f) {
    Found kept;
    std::vector<bool> seen(std::size_t(board.marker_count()), false);
    for (std::size_t i = 0; i < f.ids.size(); ++i) {
        const int index = board.index_of(f.ids[i]);
        if (index < 0 || seen[std::size_t(index)]) continue;
        seen[std::size_t(index)] = true;
        kept.ids.push_back(f.ids[i]);
        kept.corners.push_back(f.corners[i]);
    }
    f = std::move(kept);
}

cv::Rect clamp_rect(cv::Rect r, const cv::Size& size) { return r & cv::Rect(0, 0, size.width, size.height); }

// The image bounding box of the board (its markers' outer corners) at `pose`, or empty.
cv::Rect predicted_board_box(const Board& board, const Camera& camera, const Pose& pose) {
    std::vector<cv::Point3f> object;
    for (int i = 0; i < board.marker_count(); ++i)
        for (const cv::Point3f& p : board.corners(i)) object.push_back(p);
    cv::Vec3d rvec, tvec;
    pose_to_rvec_tvec(pose, rvec, tvec);
    if (tvec[2] <= 0) return {};
    std::vector<cv::Point2f> image;
    cv::projectPoints(object, rvec, tvec, camera.matrix(), camera.distortion(), image);
    return cv::boundingRect(image);
}

double reprojection_rms(const std::vector<cv::Point3d>& object, const std::vector<cv::Point2d>& image,
                        const cv::Matx33d& k, const cv::Vec3d& rvec, const cv::Vec3d& tvec,
                        std::vector<double>* per_point = nullptr) {
    std::vector<cv::Point2d> projected;
    cv::projectPoints(object, rvec, tvec, k, cv::noArray(), projected);
    double sum = 0;
    if (per_point) per_point->resize(image.size());
    for (std::size_t i = 0; i < image.size(); ++i) {
        const double e2 = (projected[i].x - image[i].x) * (projected[i].x - image[i].x) +
                          (projected[i].y - image[i].y) * (projected[i].y - image[i].y);
        sum += e2;
        if (per_point) (*per_point)[i] = e2;
    }
    return std::sqrt(sum / double(std::max<std::size_t>(1, image.size())));
}

}  // namespace

Detector::Detector(const Board& board, const Camera& camera, DetectorOptions options)
    : board_(board), camera_(camera), options_(options) {
    if (camera.width < 16 || camera.height < 16 || !(camera.fx > 0) || !(camera.fy > 0))
        throw InputError("tracking: the camera's intrinsics are unusable (size or focal length)");
    half_params_ = cv::aruco::DetectorParameters::create();
    half_params_->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;
    // Two adaptive-threshold windows (7 and 17 half-size pixels) instead of three: measured as
    // reliable on the benchmark's views and a third faster (docs/tracking.md).
    half_params_->adaptiveThreshWinSizeMin = 7;
    half_params_->adaptiveThreshWinSizeMax = 17;
    half_params_->adaptiveThreshWinSizeStep = 10;
    full_params_ = cv::aruco::DetectorParameters::create();
    full_params_->cornerRefinementMethod =
        options.edge_refinement ? cv::aruco::CORNER_REFINE_NONE : cv::aruco::CORNER_REFINE_SUBPIX;
    if (options.edge_refinement) {
        // The full-resolution search looks for small markers only (the half-size pass found the
        // rest), at twice the size when the region is small: one window of 9 pixels.
        full_params_->adaptiveThreshWinSizeMin = 9;
        full_params_->adaptiveThreshWinSizeMax = 9;
        // Small, blurred markers read with a bit or two wrong: accept more correction (a wrong id
        // is caught by the pose: its corners do not fit the board).
        full_params_->errorCorrectionRate = 1.0;
        full_params_->maxErroneousBitsInBorderRate = 0.5;
    }
}

Detection Detector::detect(const cv::Mat& gray, const std::optional<Pose>& prior) const {
    if (gray.type() != CV_8UC1 || gray.cols != camera_.width || gray.rows != camera_.height)
        throw InputError("tracking: a frame of " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                         " does not match the calibration's " + std::to_string(camera_.width) + "x" +
                         std::to_string(camera_.height) + " (or is not 8-bit grey)");
    Detection result;
    using Clock = std::chrono::steady_clock;
    const auto ms_since = [](Clock::time_point t) {
        return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
    };
    auto t_start = Clock::now();
    const Found found = search(gray, prior, result);
    result.markers_found = int(found.ids.size());
    result.search_ms = ms_since(t_start);
    if (result.markers_found < options_.min_search_markers) {
        result.rejection = "too few markers (" + std::to_string(result.markers_found) + ")";
        return result;
    }

    // Corners: refined and undistorted, grouped by marker.
    t_start = Clock::now();
    std::vector<int> marker_index;
    std::vector<std::array<cv::Point2d, 4>> image_corners;
    std::vector<bool> on_board(std::size_t(board_.marker_count()), false);
    for (std::size_t i = 0; i < found.ids.size(); ++i) {
        std::array<cv::Point2d, 4> u;
        if (options_.edge_refinement) {
            const std::array<cv::Point2f, 4> c{found.corners[i][0], found.corners[i][1], found.corners[i][2],
                                               found.corners[i][3]};
            if (!refine_marker_corners(gray, camera_, c, u)) continue;
        } else {
            const std::vector<cv::Point2d> d(found.corners[i].begin(), found.corners[i].end());
            const std::vector<cv::Point2d> und = undistort_pixels(camera_, d);
            std::copy(und.begin(), und.end(), u.begin());
        }
        marker_index.push_back(board_.index_of(found.ids[i]));
        on_board[std::size_t(marker_index.back())] = true;
        image_corners.push_back(u);
    }
    result.markers_refined = int(marker_index.size());
    result.refine_ms = ms_since(t_start);
    t_start = Clock::now();
    // Two markers (eight corners) are enough to predict the others from.
    if (int(marker_index.size()) < 2) {
        result.rejection = "too few markers with clear edges (" + std::to_string(marker_index.size()) + ")";
        return result;
    }
    const cv::Matx33d k = camera_.matrix();
    std::vector<cv::Point3d> object;
    std::vector<cv::Point2d> image;
    std::vector<bool> use(marker_index.size(), true);
    const auto gather = [&] {
        object.clear();
        image.clear();
        for (std::size_t m = 0; m < marker_index.size(); ++m) {
            if (!use[m]) continue;
            for (int c = 0; c < 4; ++c) {
                object.push_back(board_.corners(marker_index[m])[c]);
                image.push_back(image_corners[m][c]);
            }
        }
    };
    gather();

    // IPPE's two solutions of the plane. When they fit alike (the planar ambiguity of a far or
    // small board), the one whose predicted markers are found (below) decides, else the one
    // nearer the previous pose, else the frame is rejected.
    const auto ippe = [&](std::vector<Pose>& poses, std::vector<double>& errors) {
        std::vector<cv::Mat> rvecs, tvecs;
        errors.clear();
        poses.clear();
        cv::solvePnPGeneric(object, image, k, cv::noArray(), rvecs, tvecs, false, cv::SOLVEPNP_IPPE, cv::noArray(),
                            cv::noArray(), errors);
        for (std::size_t i = 0; i < rvecs.size(); ++i)
            poses.push_back(pose_from_rvec_tvec(cv::Vec3d(rvecs[i]), cv::Vec3d(tvecs[i])));
        if (poses.size() > 1 && errors[1] < errors[0]) {
            std::swap(poses[0], poses[1]);
            std::swap(errors[0], errors[1]);
        }
    };
    const auto ambiguous = [&](const std::vector<Pose>& poses, const std::vector<double>& errors) {
        return poses.size() > 1 && rotation_error_deg(poses[0], poses[1]) > 0.5 &&
               errors[1] < options_.ambiguity_ratio * errors[0] + options_.ambiguity_margin_px;
    };
    std::vector<Pose> poses;
    std::vector<double> errors;
    ippe(poses, errors);
    if (poses.empty()) {
        result.rejection = "no pose";
        return result;
    }
    const bool first_ambiguous = ambiguous(poses, errors);
    if (!first_ambiguous) poses.resize(1);

    // Markers the search missed (too small at half size, partly covered) are looked for where a
    // pose puts them; their edges refined the same way. Returns how many were found.
    const std::size_t searched = marker_index.size();
    const auto add_predicted = [&](const Pose& pose) {
        marker_index.resize(searched);
        image_corners.resize(searched);
        use.assign(searched, true);
        if (!options_.edge_refinement || !options_.predicted_markers || pose.translation.z <= 0) return 0;
        std::vector<cv::Point3f> predicted_object;
        std::vector<int> predicted_index;
        for (int i = 0; i < board_.marker_count(); ++i) {
            if (on_board[std::size_t(i)]) continue;
            predicted_index.push_back(i);
            for (const cv::Point3f& p : board_.corners(i)) predicted_object.push_back(p);
        }
        if (predicted_index.empty()) return 0;
        cv::Vec3d rv, tv;
        pose_to_rvec_tvec(pose, rv, tv);
        std::vector<cv::Point2f> projected;
        cv::projectPoints(predicted_object, rv, tv, k, camera_.distortion(), projected);
        int added = 0;
        for (std::size_t m = 0; m < predicted_index.size(); ++m) {
            std::array<cv::Point2f, 4> c;
            bool inside = true;
            for (int j = 0; j < 4; ++j) {
                c[j] = projected[4 * m + j];
                inside = inside && c[j].x > 4 && c[j].y > 4 && double(c[j].x) < gray.cols - 5 &&
                         double(c[j].y) < gray.rows - 5;
            }
            double side = 1e9;
            for (int j = 0; j < 4; ++j) side = std::min(side, double(cv::norm(c[(j + 1) % 4] - c[j])));
            if (!inside || side < 12) continue;
            std::array<cv::Point2d, 4> u;
            if (!refine_marker_corners(gray, camera_, c, u)) continue;
            marker_index.push_back(predicted_index[m]);
            image_corners.push_back(u);
            use.push_back(true);
            ++added;
        }
        return added;
    };
    cv::Vec3d rvec, tvec;
    int best_added = -1;
    double best_rms = 1e9;
    for (std::size_t i = 0; i < poses.size(); ++i) {
        gather();
        cv::Vec3d rv, tv;
        pose_to_rvec_tvec(poses[i], rv, tv);
        cv::solvePnPRefineLM(object, image, k, cv::noArray(), rv, tv);
        const int added = add_predicted(pose_from_rvec_tvec(rv, tv));
        gather();
        if (added > 0) cv::solvePnPRefineLM(object, image, k, cv::noArray(), rv, tv);
        const double rms = reprojection_rms(object, image, k, rv, tv);
        if (added > best_added || (added == best_added && rms < best_rms)) {
            best_added = added, best_rms = rms;
            rvec = rv, tvec = tv;
        }
    }
    if (poses.size() > 1) {
        // Run again for the chosen solution (the lists hold the last one tried).
        add_predicted(pose_from_rvec_tvec(rvec, tvec));
        gather();
        cv::solvePnPRefineLM(object, image, k, cv::noArray(), rvec, tvec);
    }
    result.markers_predicted = std::max(0, best_added);

    // Drop markers whose corners fit badly (a corner pulled by an occluder), solve again.
    std::vector<double> e2;
    reprojection_rms(object, image, k, rvec, tvec, &e2);
    std::vector<double> marker_rms;
    for (std::size_t m = 0; m < marker_index.size(); ++m)
        marker_rms.push_back(std::sqrt(0.25 * (e2[4 * m] + e2[4 * m + 1] + e2[4 * m + 2] + e2[4 * m + 3])));
    std::vector<double> sorted = marker_rms;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const double limit = std::max(0.5, 4 * sorted[sorted.size() / 2]);
    int dropped = 0;
    for (std::size_t m = 0; m < marker_index.size(); ++m)
        if (marker_rms[m] > limit) use[m] = false, ++dropped;
    if (dropped > 0) {
        gather();
        if (int(marker_index.size()) - dropped < options_.min_markers) {
            result.rejection = "too few markers fit the pose";
            return result;
        }
        cv::solvePnPRefineLM(object, image, k, cv::noArray(), rvec, tvec);
    }
    if (poses.size() > 1) {
        // Ambiguous at first: with every marker found and the outliers gone, both IPPE solutions
        // refined; if they are still distinct and fit alike, the previous pose decides, or
        // nothing does.
        std::vector<Pose> again;
        std::vector<double> again_errors;
        ippe(again, again_errors);
        if (again.size() > 1) {
            std::array<cv::Vec3d, 2> rv, tv;
            std::array<double, 2> rms{};
            for (int i = 0; i < 2; ++i) {
                pose_to_rvec_tvec(again[std::size_t(i)], rv[i], tv[i]);
                cv::solvePnPRefineLM(object, image, k, cv::noArray(), rv[i], tv[i]);
                rms[i] = reprojection_rms(object, image, k, rv[i], tv[i]);
            }
            const int lower = rms[1] < rms[0] ? 1 : 0, higher = 1 - lower;
            const Pose a = pose_from_rvec_tvec(rv[lower], tv[lower]), b = pose_from_rvec_tvec(rv[higher], tv[higher]);
            if (rotation_error_deg(a, b) > 0.5 &&
                rms[higher] < options_.ambiguity_ratio * rms[lower] + options_.ambiguity_margin_px) {
                if (!prior) {
                    result.rejection = "ambiguous pose (the two IPPE solutions fit alike)";
                    return result;
                }
                const int chosen = rotation_error_deg(b, *prior) < rotation_error_deg(a, *prior) ? higher : lower;
                rvec = rv[chosen], tvec = tv[chosen];
            } else {
                rvec = rv[lower], tvec = tv[lower];
            }
        }
    }
    result.markers = int(marker_index.size()) - dropped;
    if (result.markers < options_.min_markers) {
        result.rejection = "too few markers (" + std::to_string(result.markers) + ")";
        return result;
    }
    result.rms_px = reprojection_rms(object, image, k, rvec, tvec);
    result.pose = pose_from_rvec_tvec(rvec, tvec);
    result.pose_ms = ms_since(t_start);
    if (result.rms_px > options_.max_rms_px) {
        result.rejection = "reprojection RMS " + std::to_string(result.rms_px) + " px above the limit";
        return result;
    }
    if (tvec[2] <= 0) {
        result.rejection = "board behind the camera";
        return result;
    }
    result.detected = true;
    return result;
}

Detector::Found Detector::search(const cv::Mat& gray, const std::optional<Pose>& prior, Detection& result) const {
    Found found;
    std::vector<std::vector<cv::Point2f>> candidates;
    if (!options_.edge_refinement) {
        // The comparison pipeline: ArUco alone at full resolution.
        result.full_resolution_search = true;
        cv::aruco::detectMarkers(gray, board_.dictionary(), found.corners, found.ids, full_params_);
        keep_board_markers(board_, found);
        return found;
    }
    cv::Mat half;
    cv::resize(gray, half, cv::Size(gray.cols / 2, gray.rows / 2), 0, 0, cv::INTER_AREA);
    cv::aruco::detectMarkers(half, board_.dictionary(), found.corners, found.ids, half_params_, candidates);
    keep_board_markers(board_, found);
    // Half-size pixel centre i is full-size coordinate 2 i + 0.5.
    const auto to_full = [](std::vector<cv::Point2f>& marker) {
        for (cv::Point2f& p : marker) p = 2.0f * p + cv::Point2f(0.5f, 0.5f);
    };
    for (auto& marker : found.corners) to_full(marker);
    for (auto& c : candidates) to_full(c);
    // Enough markers to predict the others from: done.
    if (int(found.ids.size()) >= options_.min_search_markers) return found;
    // The full-resolution search, in the smallest region that can hold the board: the board
    // predicted by the previous pose, else the markers and square candidates of the half-size
    // pass, else the whole frame.
    cv::Rect box;
    if (prior) box = predicted_board_box(board_, camera_, *prior);
    if (box.empty()) {
        for (const auto& marker : found.corners) box |= cv::boundingRect(marker);
        for (const auto& c : candidates) box |= cv::boundingRect(c);
    }
    cv::Rect roi(0, 0, gray.cols, gray.rows);
    if (!box.empty()) {
        const int pad = std::max(box.width, box.height) / 4 + 16;
        roi = clamp_rect(cv::Rect(box.x - pad, box.y - pad, box.width + 2 * pad, box.height + 2 * pad), gray.size());
        // A board predicted wholly outside the frame (it left the view): the whole frame, since
        // the prediction is what is in doubt.
        if (roi.empty()) roi = cv::Rect(0, 0, gray.cols, gray.rows);
    }
    result.full_resolution_search = true;
    Found full;
    // A small region is searched at twice the size: the cells of a far, steep board's markers
    // are under 2 pixels, and the detector's contours and bit sampling need more.
    const bool upscale = roi.area() * 6 < gray.cols * gray.rows;
    cv::Mat region = gray(roi);
    if (upscale) cv::resize(region, region, cv::Size(), 2, 2, cv::INTER_LINEAR);
    cv::aruco::detectMarkers(region, board_.dictionary(), full.corners, full.ids, full_params_);
    keep_board_markers(board_, full);
    for (auto& marker : full.corners)
        for (cv::Point2f& p : marker) {
            // Twice-size pixel centre j is region coordinate (j + 0.5) / 2 - 0.5.
            if (upscale) p = 0.5f * (p + cv::Point2f(0.5f, 0.5f)) - cv::Point2f(0.5f, 0.5f);
            p += cv::Point2f(float(roi.x), float(roi.y));
        }
    return full.ids.size() > found.ids.size() ? full : found;
}

}  // namespace glint::tracking
