#include "appliance/tracking/board.hpp"

#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "appliance/core/errors.hpp"

namespace glint::tracking {
namespace {

const std::map<std::string, int>& dictionaries() {
    static const std::map<std::string, int> names = {
        {"DICT_4X4_50", cv::aruco::DICT_4X4_50},   {"DICT_4X4_100", cv::aruco::DICT_4X4_100},
        {"DICT_4X4_250", cv::aruco::DICT_4X4_250}, {"DICT_5X5_50", cv::aruco::DICT_5X5_50},
        {"DICT_5X5_100", cv::aruco::DICT_5X5_100}, {"DICT_5X5_250", cv::aruco::DICT_5X5_250},
        {"DICT_6X6_50", cv::aruco::DICT_6X6_50},   {"DICT_6X6_250", cv::aruco::DICT_6X6_250},
    };
    return names;
}

int dictionary_size(int id) {
    switch (id) {
    case cv::aruco::DICT_4X4_50: case cv::aruco::DICT_5X5_50: case cv::aruco::DICT_6X6_50: return 50;
    case cv::aruco::DICT_4X4_100: case cv::aruco::DICT_5X5_100: return 100;
    default: return 250;
    }
}

}  // namespace

Board::Board(const BoardSpec& spec) : spec_(spec) {
    const auto dict = dictionaries().find(spec.dictionary);
    if (dict == dictionaries().end()) throw InputError("board: unknown dictionary '" + spec.dictionary + "'");
    if (spec.columns < 1 || spec.rows < 1 || spec.columns * spec.rows < 2)
        throw InputError("board: at least 2 markers are needed");
    if (!(spec.marker_mm > 0) || !(spec.gap_mm >= 0) || !(spec.margin_mm >= 0))
        throw InputError("board: marker_mm must be > 0, gap_mm and margin_mm >= 0");
    if (spec.first_id < 0 || spec.first_id + spec.columns * spec.rows > dictionary_size(dict->second))
        throw InputError("board: ids " + std::to_string(spec.first_id) + ".." +
                         std::to_string(spec.first_id + spec.columns * spec.rows - 1) + " exceed " + spec.dictionary);
    dictionary_ = cv::aruco::getPredefinedDictionary(dict->second);
    const double m = spec.marker_mm / 1000, pitch = (spec.marker_mm + spec.gap_mm) / 1000;
    const double grid_w = spec.columns * m + (spec.columns - 1) * spec.gap_mm / 1000;
    const double grid_h = spec.rows * m + (spec.rows - 1) * spec.gap_mm / 1000;
    for (int r = 0; r < spec.rows; ++r)
        for (int c = 0; c < spec.columns; ++c) {
            // Row 0 is at the top: +Y up.
            const double left = -grid_w / 2 + c * pitch, top = grid_h / 2 - r * pitch;
            const auto f = [](double v) { return float(v); };
            corners_.push_back({cv::Point3f(f(left), f(top), 0), cv::Point3f(f(left + m), f(top), 0),
                                cv::Point3f(f(left + m), f(top - m), 0), cv::Point3f(f(left), f(top - m), 0)});
        }
}

double Board::width_m() const {
    return (spec_.columns * spec_.marker_mm + (spec_.columns - 1) * spec_.gap_mm + 2 * spec_.margin_mm) / 1000;
}
double Board::height_m() const {
    return (spec_.rows * spec_.marker_mm + (spec_.rows - 1) * spec_.gap_mm + 2 * spec_.margin_mm) / 1000;
}

int Board::index_of(int id) const {
    const int i = id - spec_.first_id;
    return i >= 0 && i < marker_count() ? i : -1;
}

cv::Ptr<cv::aruco::Board> Board::aruco_board() const {
    std::vector<std::vector<cv::Point3f>> points;
    std::vector<int> ids;
    for (int i = 0; i < marker_count(); ++i) {
        points.emplace_back(corners_[i].begin(), corners_[i].end());
        ids.push_back(spec_.first_id + i);
    }
    return cv::aruco::Board::create(points, dictionary_, ids);
}

BoardSpec board_spec_from_json(const std::string& text, const std::string& source) {
    nlohmann::json j;
    try {
        j = nlohmann::json::parse(text);
    } catch (const nlohmann::json::exception& e) {  // parse_error, and out_of_range for a number beyond double's range
        throw InputError(source + ": not JSON: " + e.what());
    }
    if (!j.is_object()) throw InputError(source + ": the board must be a JSON object");
    BoardSpec s;
    const auto key_error = [&](const std::string& key, const std::string& why) {
        return InputError(source + ": key '" + key + "': " + why);
    };
    const auto get_int = [&](const std::string& key, const nlohmann::json& v, int lo, int hi) {
        if (!v.is_number_integer()) throw key_error(key, "must be a whole number");
        const long long n = v.get<long long>();
        if (n < lo || n > hi) throw key_error(key, "must be in " + std::to_string(lo) + ".." + std::to_string(hi));
        return int(n);
    };
    const auto get_mm = [&](const std::string& key, const nlohmann::json& v, bool zero_ok) {
        if (!v.is_number()) throw key_error(key, "must be a number (millimetres)");
        const double d = v.get<double>();
        if (!(zero_ok ? d >= 0 : d > 0) || d > 10000) throw key_error(key, zero_ok ? "must be in 0..10000" : "must be in (0, 10000]");
        return d;
    };
    for (const auto& [key, v] : j.items()) {
        if (key == "columns") s.columns = get_int(key, v, 1, 100);
        else if (key == "rows") s.rows = get_int(key, v, 1, 100);
        else if (key == "first_id") s.first_id = get_int(key, v, 0, 1000);
        else if (key == "marker_mm") s.marker_mm = get_mm(key, v, false);
        else if (key == "gap_mm") s.gap_mm = get_mm(key, v, true);
        else if (key == "margin_mm") s.margin_mm = get_mm(key, v, true);
        else if (key == "dictionary") {
            if (!v.is_string()) throw key_error(key, "must be a string such as \"DICT_4X4_50\"");
            s.dictionary = v.get<std::string>();
            if (!dictionaries().count(s.dictionary)) throw key_error(key, "unknown dictionary '" + s.dictionary + "'");
        } else {
            throw key_error(key, "unknown key (known: columns, rows, marker_mm, gap_mm, margin_mm, dictionary, first_id)");
        }
    }
    try {
        Board check(s);
    } catch (const InputError& e) {
        throw InputError(source + ": " + e.what());
    }
    return s;
}

BoardSpec load_board_spec(const std::filesystem::path& path) {
    std::ifstream in(path);
    if (!in) throw InputError(path.string() + ": cannot be read");
    std::stringstream ss;
    ss << in.rdbuf();
    return board_spec_from_json(ss.str(), path.string());
}

}  // namespace glint::tracking
