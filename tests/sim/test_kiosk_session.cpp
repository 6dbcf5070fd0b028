// The readers of a kiosk session's extra files (appliance/capture/kiosk_session.hpp): what the
// writers write is read back unchanged, absent files are empty, and every malformed line or key
// is an InputError that names the file and the line or key.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <unistd.h>

#include "appliance/capture/kiosk_session.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/rotation.hpp"
#include "appliance/tracking/board.hpp"

namespace glint::capture {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& p, const std::string& text) {
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
}

// The InputError `f` throws must contain every fragment.
void expect_input_error(const std::function<void()>& f, const std::vector<std::string>& fragments) {
    try {
        f();
        ADD_FAILURE() << "no InputError; expected one naming " << fragments.front();
    } catch (const InputError& e) {
        for (const std::string& s : fragments)
            EXPECT_NE(std::string(e.what()).find(s), std::string::npos) << "'" << e.what() << "' lacks '" << s << "'";
    }
}

class KioskSessionFiles : public ::testing::Test {
protected:
    void SetUp() override {
        session_.dir = fs::temp_directory_path() / ("glint-kiosk-files-" + std::to_string(::getpid()));
        fs::remove_all(session_.dir);
        fs::create_directories(session_.dir);
        for (int k = 0; k < 4; ++k)
            session_.frames.push_back({std::uint64_t(k), 1'000'000'000 + k * 100'000'000LL, 0.01, 1, 1, "f.png"});
    }
    void TearDown() override { fs::remove_all(session_.dir); }

    KioskSessionInfo info() const {
        KioskSessionInfo i;
        i.phases = {{"attract", 1'000'000'000, 4'000'000'000}, {"scan", 4'000'000'000, 60'000'000'000},
                    {"ar", 62'000'000'000, 74'000'000'000}};
        i.board_json = R"({"columns":5,"rows":7,"marker_mm":40,"gap_mm":10,"margin_mm":20,"dictionary":"DICT_4X4_50","first_id":0})";
        i.table_height_m = 0.75;
        i.world_from_board = glm::angleAxis(-0.5 * kPi, glm::dvec3(1, 0, 0));
        i.world_board_t = {0.1, 0.75, -0.05};
        return i;
    }
    // kiosk.json as written, with `edit` applied to the text.
    void write_kiosk(const std::function<void(std::string&)>& edit) {
        std::string text = kiosk_json(info());
        edit(text);
        write(session_.dir / "kiosk.json", text);
    }
    static void replace(std::string& text, const std::string& from, const std::string& to) {
        const std::size_t at = text.find(from);
        ASSERT_NE(at, std::string::npos) << from;
        text.replace(at, from.size(), to);
    }
    std::string file(const char* rel) const { return (session_.dir / rel).string(); }

    Session session_;
};

TEST_F(KioskSessionFiles, AbsentFilesAreEmpty) {
    EXPECT_TRUE(load_session_events(session_).empty());
    EXPECT_FALSE(load_kiosk_info(session_).has_value());
    EXPECT_TRUE(load_truth_board_poses(session_).empty());
}

TEST_F(KioskSessionFiles, WhatIsWrittenIsReadBack) {
    const std::vector<SessionEvent> events = {{5'000'000'000, "button", "press"}, {5'080'000'000, "button", "release"}};
    std::string csv = session_events_csv_header() + "\n";
    for (const SessionEvent& e : events) csv += session_events_csv_line(e) + "\n";
    EXPECT_EQ(csv, "t_ns,source,event\n5000000000,button,press\n5080000000,button,release\n");
    write(session_.dir / "events.csv", csv);
    const std::vector<SessionEvent> read = load_session_events(session_);
    ASSERT_EQ(read.size(), 2u);
    for (std::size_t i = 0; i < 2; ++i) {
        EXPECT_EQ(read[i].t_ns, events[i].t_ns);
        EXPECT_EQ(read[i].source, events[i].source);
        EXPECT_EQ(read[i].event, events[i].event);
    }

    write(session_.dir / "kiosk.json", kiosk_json(info()));
    const std::optional<KioskSessionInfo> k = load_kiosk_info(session_);
    ASSERT_TRUE(k.has_value());
    ASSERT_EQ(k->phases.size(), 3u);
    for (std::size_t i = 0; i < 3; ++i) {
        EXPECT_EQ(k->phases[i].name, info().phases[i].name);
        EXPECT_EQ(k->phases[i].start_ns, info().phases[i].start_ns);
        EXPECT_EQ(k->phases[i].end_ns, info().phases[i].end_ns);
    }
    ASSERT_NE(k->phase("ar"), nullptr);
    EXPECT_EQ(k->phase("ar")->start_ns, 62'000'000'000);
    EXPECT_EQ(k->phase("processing"), nullptr);
    EXPECT_DOUBLE_EQ(k->table_height_m, 0.75);
    EXPECT_NEAR(angle_between(k->world_from_board, info().world_from_board), 0, 1e-7);
    EXPECT_NEAR(glm::length(k->world_board_t - info().world_board_t), 0, 1e-12);
    // Board +Z (out of the print) is world +Y (up): the board lies on the level table.
    EXPECT_NEAR(glm::length(k->world_from_board * glm::dvec3(0, 0, 1) - glm::dvec3(0, 1, 0)), 0, 1e-9);
    // The board text is what tracking reads.
    const tracking::BoardSpec spec = tracking::board_spec_from_json(k->board_json, "kiosk.json board");
    EXPECT_EQ(spec.columns, 5);
    EXPECT_EQ(spec.rows, 7);
    EXPECT_EQ(spec.dictionary, "DICT_4X4_50");

    std::string board = truth_board_csv_header() + "\n";
    TruthBoardPose p;
    p.index = 2;
    p.t_ns = session_.frames[2].t_ns;
    p.camera_from_board = glm::normalize(glm::dquat(0.1, 0.9, -0.3, 0.2));
    p.t_m = {0.01, -0.02, 0.6};
    board += truth_board_csv_line(p) + "\n";
    write(session_.dir / "truth" / "board.csv", board);
    const std::vector<TruthBoardPose> poses = load_truth_board_poses(session_);
    ASSERT_EQ(poses.size(), 1u);
    EXPECT_EQ(poses[0].index, 2u);
    EXPECT_EQ(poses[0].t_ns, p.t_ns);
    EXPECT_NEAR(angle_between(poses[0].camera_from_board, p.camera_from_board), 0, 1e-7);
    EXPECT_NEAR(glm::length(poses[0].t_m - p.t_m), 0, 1e-9);
}

TEST_F(KioskSessionFiles, MalformedEventsNameTheFileAndLine) {
    const fs::path p = session_.dir / "events.csv";
    write(p, "time,source,event\n1,button,press\n");
    expect_input_error([&] { load_session_events(session_); }, {file("events.csv") + ":1:", "header"});
    write(p, "t_ns,source,event\n1,button,press\n2.5,button,release\n");
    expect_input_error([&] { load_session_events(session_); }, {file("events.csv") + ":3:", "t_ns", "2.5"});
    write(p, "t_ns,source,event\n1,button,press\n\n2,button\n");
    expect_input_error([&] { load_session_events(session_); }, {file("events.csv") + ":4:", "2 fields"});
    write(p, "t_ns,source,event\n10,button,press\n9,button,release\n");
    expect_input_error([&] { load_session_events(session_); }, {file("events.csv") + ":3:", "must not decrease"});
    write(p, "t_ns,source,event\n10,,press\n");
    expect_input_error([&] { load_session_events(session_); }, {file("events.csv") + ":2:", "source"});
    write(p, "t_ns,source,event\n10,button,pre ss\n");
    expect_input_error([&] { load_session_events(session_); }, {file("events.csv") + ":2:", "event 'pre ss'"});
}

TEST_F(KioskSessionFiles, MalformedKioskJsonNamesTheFileAndKey) {
    const std::string f = file("kiosk.json");
    const auto load = [&] { load_kiosk_info(session_); };
    write_kiosk([](std::string& t) { t.pop_back(), t.pop_back(); });  // the closing brace gone
    expect_input_error(load, {f, "not valid JSON"});
    write_kiosk([](std::string& t) { replace(t, "\"version\": 1", "\"version\": 2"); });
    expect_input_error(load, {f, "key 'version'"});
    write_kiosk([](std::string& t) { replace(t, "\"glint-kiosk-session\"", "\"glint-session\""); });
    expect_input_error(load, {f, "key 'format'"});
    write_kiosk([](std::string& t) { replace(t, "\"table_height_m\"", "\"table_height\""); });
    expect_input_error(load, {f, "key 'table_height'", "unknown key"});
    write_kiosk([](std::string& t) { replace(t, "\"end_ns\": 60000000000", "\"end_ns\": 3000000000"); });
    expect_input_error(load, {f, "key 'phases[1].end_ns'", "after start_ns"});
    write_kiosk([](std::string& t) { replace(t, "\"start_ns\": 62000000000", "\"start_ns\": 59000000000"); });
    expect_input_error(load, {f, "key 'phases[2].start_ns'", "time order"});
    write_kiosk([](std::string& t) { replace(t, "\"start_ns\": 62000000000", "\"start_ns\": 6.2e10"); });
    expect_input_error(load, {f, "key 'phases[2].start_ns'", "whole number"});
    write_kiosk([](std::string& t) { replace(t, "\"name\": \"ar\"", "\"name\": \"scan\""); });
    expect_input_error(load, {f, "key 'phases[2].name'", "twice"});
    write_kiosk([](std::string& t) { replace(t, "\"board\": {", "\"board\": 5, \"x\": {"); });
    expect_input_error(load, {f, "key 'x'"});
    write_kiosk([](std::string& t) { replace(t, "\"w\": ", "\"w\": 0.5 + 0 * "); });
    expect_input_error(load, {f, "not valid JSON"});
    // A number beyond double's range: nlohmann throws out_of_range, not parse_error.
    write_kiosk([](std::string& t) { replace(t, "\"table_height_m\": 0.75", "\"table_height_m\": 1e999"); });
    expect_input_error(load, {f, "not valid JSON"});
    write_kiosk([](std::string& t) { replace(t, "\"w\": ", "\"w\": 0.1, \"ww\": "); });
    expect_input_error(load, {f, "key 'world_from_board.ww'"});
    write_kiosk([](std::string& t) { replace(t, "\"table_height_m\": 0.75", "\"table_height_m\": \"high\""); });
    expect_input_error(load, {f, "key 'table_height_m'", "number"});
    write_kiosk([](std::string& t) { replace(t, "\"t\": [", "\"t\": [1, "); });
    expect_input_error(load, {f, "key 'world_from_board.t'", "3 numbers"});
    write(session_.dir / "kiosk.json", R"({"format": "glint-kiosk-session", "version": 1, "phases": [], "board": {},
        "table_height_m": 0.7, "world_from_board": {"w": 1, "x": 0, "y": 0, "z": 0, "t": [0, 0, 0]}})");
    expect_input_error(load, {f, "key 'phases'", "non-empty"});
    write(session_.dir / "kiosk.json", R"({"format": "glint-kiosk-session", "version": 1,
        "phases": [{"name": "ar", "start_ns": 1, "end_ns": 2}], "board": [1],
        "table_height_m": 0.7, "world_from_board": {"w": 1, "x": 0, "y": 0, "z": 0, "t": [0, 0, 0]}})");
    expect_input_error(load, {f, "key 'board'"});
    write(session_.dir / "kiosk.json", R"({"format": "glint-kiosk-session", "version": 1,
        "phases": [{"name": "ar", "start_ns": 1, "end_ns": 2}], "board": {},
        "table_height_m": 0.7, "world_from_board": {"w": 2, "x": 0, "y": 0, "z": 0, "t": [0, 0, 0]}})");
    expect_input_error(load, {f, "key 'world_from_board'", "length"});
    write(session_.dir / "kiosk.json", R"({"format": "glint-kiosk-session", "version": 1,
        "phases": [{"name": "ar", "start_ns": 1, "end_ns": 2}], "board": {},
        "world_from_board": {"w": 1, "x": 0, "y": 0, "z": 0, "t": [0, 0, 0]}})");
    expect_input_error(load, {f, "key 'table_height_m'", "missing"});
}

TEST_F(KioskSessionFiles, MalformedBoardTruthNamesTheFileAndLine) {
    const fs::path p = session_.dir / "truth" / "board.csv";
    const std::string f = file("truth/board.csv");
    const std::string header = truth_board_csv_header() + "\n";
    const auto load = [&] { load_truth_board_poses(session_); };
    write(p, header + "1,1100000000,1,0,0,0,0,0,0.5\n2,1200000000,1,0,0,x,0,0,0.5\n");
    expect_input_error(load, {f + ":3:", "qz", "'x'"});
    write(p, header + "7,1100000000,1,0,0,0,0,0,0.5\n");
    expect_input_error(load, {f + ":2:", "index 7"});
    write(p, header + "1,1100000001,1,0,0,0,0,0,0.5\n");
    expect_input_error(load, {f + ":2:", "t_ns differs"});
    write(p, header + "2,1200000000,1,0,0,0,0,0,0.5\n1,1100000000,1,0,0,0,0,0,0.5\n");
    expect_input_error(load, {f + ":3:", "must increase"});
    write(p, header + "1,1100000000,0.9,0,0,0,0,0,0.5\n");
    expect_input_error(load, {f + ":2:", "length"});
    write(p, header + "1,1100000000,1,0,0,0,0,0\n");
    expect_input_error(load, {f + ":2:", "8 fields"});
    write(p, "index,t_ns,w,x,y,z\n");
    expect_input_error(load, {f + ":1:", "header"});
}

}  // namespace
}  // namespace glint::capture
