// The state store (appliance/core/state_store.hpp) and the items the appliance keeps in it: saved
// whole, verified on load, and every kind of damage detected, set aside into corrupt/ (never
// deleted), logged with the file and the reason, and replaced by the defaults.
#include <gtest/gtest.h>

#include <functional>

#include "appliance/capture/calibration_io.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/scene_state.hpp"
#include "appliance/core/state_store.hpp"
#include "appliance/ui/pin_lock.hpp"
#include "tests/faults/faults_support.hpp"
#include "tests/faults/state_versions.hpp"

namespace glint::faults {
namespace {

namespace fs = std::filesystem;
using state::LoadPolicy;

struct Logged {
    std::vector<std::string> lines;
    state::Log log() {
        return [this](const std::string& l) { lines.push_back(l); };
    }
    std::string all() const {
        std::string s;
        for (const auto& l : lines) s += l + "\n";
        return s;
    }
};

LoadPolicy two_files() {
    LoadPolicy p;
    p.files = {"a.txt", "b.txt"};
    return p;
}

void save_two(const fs::path& dir, const std::string& a, const std::string& b) {
    state::save_item(dir, "item", {state::text_file("a.txt", a), state::text_file("b.txt", b)});
}

int generations(const fs::path& dir, const std::string& item) {
    int n = 0;
    for (const auto& e : fs::directory_iterator(dir / ("." + item + ".gen"))) (void)e, ++n;
    return n;
}

TEST(StateStore, ADirectoryItemIsReadThroughItsPath) {
    TempDir t;
    save_two(t.path(), "first a", "first b");
    save_two(t.path(), "second a", "second b");
    EXPECT_EQ(read_text(t.path() / "item" / "a.txt"), "second a");
    EXPECT_EQ(read_text(t.path() / "item" / "b.txt"), "second b");
    EXPECT_TRUE(state::is_store_item(t.path() / "item"));
    EXPECT_EQ(generations(t.path(), "item"), 1);  // the old one removed once the new one is linked
    Logged logged;
    const state::LoadedItem r = state::load_item(t.path(), "item", two_files(), logged.log());
    ASSERT_TRUE(r.path);
    EXPECT_TRUE(r.verified);
    EXPECT_FALSE(r.fault);
    EXPECT_EQ(*r.path, t.path() / "item");
    EXPECT_TRUE(logged.lines.empty()) << logged.all();
}

TEST(StateStore, AFileItemIsReadAtItsOwnPath) {
    TempDir t;
    state::save_item(t.path(), "x.json", {state::text_file("x.json", "{\"v\": 1}\n")});
    state::save_item(t.path(), "x.json", {state::text_file("x.json", "{\"v\": 2}\n")});
    EXPECT_EQ(read_text(t.path() / "x.json"), "{\"v\": 2}\n");
    EXPECT_TRUE(fs::is_symlink(t.path() / "x.json"));
    LoadPolicy p;
    p.files = {"x.json"};
    const state::LoadedItem r = state::load_item(t.path(), "x.json", p, {});
    ASSERT_TRUE(r.path);
    EXPECT_TRUE(r.verified);
}

TEST(StateStore, NothingSavedYetIsNotAFault) {
    TempDir t;
    Logged logged;
    const state::LoadedItem r = state::load_item(t.path(), "item", two_files(), logged.log());
    EXPECT_FALSE(r.path);
    EXPECT_FALSE(r.fault);
    EXPECT_EQ(r.defaults_because, "none saved yet");
    EXPECT_TRUE(logged.lines.empty());
    // An empty directory made by a caller before the first save neither.
    fs::create_directory(t.path() / "item");
    EXPECT_FALSE(state::load_item(t.path(), "item", two_files(), {}).fault);
    save_two(t.path(), "a", "b");
    EXPECT_TRUE(state::load_item(t.path(), "item", two_files(), {}).verified);
    EXPECT_TRUE(set_asides(t.path()).empty());
}

// One kind of damage: what it does to an item saved with a.txt = "alpha content", b.txt = "beta".
struct Damage {
    const char* name;
    std::function<void(const fs::path& gen)> apply;
    const char* file_in_reason;  // the file the log must name
    const char* reason;          // ... and words of the reason
};

fs::path current_generation(const fs::path& dir, const std::string& item) {
    return fs::canonical(dir / item);
}

class Damaged : public ::testing::TestWithParam<Damage> {};

TEST_P(Damaged, IsDetectedSetAsideLoggedAndTheDefaultsUsed) {
    const Damage& d = GetParam();
    TempDir t;
    save_two(t.path(), "alpha content", "beta");
    const fs::path gen = current_generation(t.path(), "item");
    d.apply(gen);
    Logged logged;
    const state::LoadedItem r = state::load_item(t.path(), "item", two_files(), logged.log());
    EXPECT_FALSE(r.path);
    EXPECT_TRUE(r.fault);
    ASSERT_EQ(logged.lines.size(), 1u) << logged.all();
    const std::string& line = logged.lines[0];
    EXPECT_NE(line.find((t.path() / "item").string()), std::string::npos) << line;
    EXPECT_NE(line.find(d.file_in_reason), std::string::npos) << line;
    EXPECT_NE(line.find(d.reason), std::string::npos) << line;
    EXPECT_NE(line.find("set aside in " + (t.path() / "corrupt").string()), std::string::npos) << line;
    EXPECT_NE(line.find("using the defaults"), std::string::npos) << line;
    // Moved, not deleted: the damaged generation with its files, and why.
    const std::vector<fs::path> aside = set_asides(t.path());
    ASSERT_EQ(aside.size(), 1u);
    EXPECT_EQ(r.set_aside, aside[0]);
    EXPECT_NE(read_text(aside[0] / "REASON.txt").find(d.reason), std::string::npos);
    if (std::string(d.name) != "generation_missing") {
        EXPECT_TRUE(fs::is_directory(aside[0] / ("item.generation-" + gen.filename().string())));
    }
    EXPECT_FALSE(fs::exists(fs::symlink_status(t.path() / "item")));
    // The next start sees nothing (defaults, no new fault), and the next save works.
    Logged again;
    EXPECT_FALSE(state::load_item(t.path(), "item", two_files(), again.log()).fault);
    EXPECT_TRUE(again.lines.empty()) << again.all();
    save_two(t.path(), "new a", "new b");
    EXPECT_TRUE(state::load_item(t.path(), "item", two_files(), {}).verified);
    EXPECT_EQ(read_text(t.path() / "item" / "a.txt"), "new a");
}

INSTANTIATE_TEST_SUITE_P(
    Kinds, Damaged,
    ::testing::Values(
        Damage{"truncated", [](const fs::path& g) { fs::resize_file(g / "a.txt", 5); }, "a.txt", "5 bytes, the manifest says 13"},
        Damage{"flipped_byte",
               [](const fs::path& g) {
                   std::string s = read_text(g / "a.txt");
                   s[3] = char(s[3] ^ 0x20);
                   write_text(g / "a.txt", s);
               },
               "a.txt", "checksum"},
        Damage{"zero_length", [](const fs::path& g) { fs::resize_file(g / "b.txt", 0); }, "b.txt", "0 bytes, the manifest says 4"},
        Damage{"missing_file", [](const fs::path& g) { fs::remove(g / "b.txt"); }, "b.txt", "missing"},
        Damage{"missing_manifest", [](const fs::path& g) { fs::remove(g / "MANIFEST.json"); }, "MANIFEST.json", "missing"},
        Damage{"zero_length_manifest", [](const fs::path& g) { fs::resize_file(g / "MANIFEST.json", 0); }, "MANIFEST.json",
               "unreadable"},
        Damage{"manifest_of_another_item",
               [](const fs::path& g) {
                   std::string s = read_text(g / "MANIFEST.json");
                   s.replace(s.find("\"item\""), 14, "\"item\": \"meti\"");
                   write_text(g / "MANIFEST.json", s);
               },
               "MANIFEST.json", "another item"},
        Damage{"generation_missing", [](const fs::path& g) { fs::remove_all(g); }, "item", "is missing"}),
    [](const ::testing::TestParamInfo<Damage>& param) { return std::string(param.param.name); });

TEST(StateStore, AnItemThatDoesNotParseIsSetAside) {
    TempDir t;
    save_two(t.path(), "not a number", "b");
    LoadPolicy p = two_files();
    p.check = [](const fs::path& item) { (void)std::stoi(read_text(item / "a.txt")); };
    Logged logged;
    const state::LoadedItem r = state::load_item(t.path(), "item", p, logged.log());
    EXPECT_FALSE(r.path);
    EXPECT_TRUE(r.fault);
    ASSERT_EQ(logged.lines.size(), 1u);
    EXPECT_NE(logged.lines[0].find("does not parse"), std::string::npos) << logged.lines[0];
    EXPECT_EQ(set_asides(t.path()).size(), 1u);
}

TEST(StateStore, AnItemTheStoreDidNotWriteIsAcceptedOrSetAsideByPolicy) {
    TempDir t;
    write_text(t.path() / "hand.json", "42");
    LoadPolicy accept;
    accept.files = {"hand.json"};
    accept.unverified = state::Unverified::Accept;
    accept.check = [](const fs::path& f) { (void)std::stoi(read_text(f)); };
    Logged logged;
    const state::LoadedItem r = state::load_item(t.path(), "hand.json", accept, logged.log());
    ASSERT_TRUE(r.path);
    EXPECT_FALSE(r.verified);
    ASSERT_EQ(logged.lines.size(), 1u);
    EXPECT_NE(logged.lines[0].find("loaded unverified"), std::string::npos);
    // Accepted only if it parses.
    write_text(t.path() / "hand.json", "forty-two");
    EXPECT_TRUE(state::load_item(t.path(), "hand.json", accept, {}).fault);
    EXPECT_EQ(set_asides(t.path()).size(), 1u);
    // A plain directory where only the store writes (the scene of an older build): set aside.
    fs::create_directory(t.path() / "item");
    write_text(t.path() / "item" / "a.txt", "old");
    Logged scene;
    EXPECT_TRUE(state::load_item(t.path(), "item", two_files(), scene.log()).fault);
    EXPECT_NE(scene.all().find("not written by the state store"), std::string::npos);
    EXPECT_EQ(set_asides(t.path()).size(), 2u);
}

TEST(StateStore, ATechniciansLinkIsReadAsAnItemTheStoreDidNotWrite) {
    TempDir t;
    fs::create_directory(t.path() / "elsewhere");
    write_text(t.path() / "elsewhere" / "cal.json", "7");
    fs::create_symlink(t.path() / "elsewhere" / "cal.json", t.path() / "cal.json");
    EXPECT_FALSE(state::is_store_item(t.path() / "cal.json"));
    LoadPolicy accept;
    accept.files = {"cal.json"};
    accept.unverified = state::Unverified::Accept;
    accept.check = [](const fs::path& f) { (void)std::stoi(read_text(f)); };
    Logged logged;
    const state::LoadedItem r = state::load_item(t.path(), "cal.json", accept, logged.log());
    ASSERT_TRUE(r.path);
    EXPECT_FALSE(r.verified);
    EXPECT_NE(logged.all().find("loaded unverified"), std::string::npos);
    // A save replaces the link with the store's own; the file it pointed at is left alone.
    state::save_item(t.path(), "cal.json", {state::text_file("cal.json", "8")});
    EXPECT_TRUE(state::is_store_item(t.path() / "cal.json"));
    EXPECT_EQ(read_text(t.path() / "elsewhere" / "cal.json"), "7");
    EXPECT_TRUE(state::load_item(t.path(), "cal.json", accept, {}).verified);
}

TEST(StateStore, WhatASaveCutShortLeftIsRemoved) {
    TempDir t;
    save_two(t.path(), "a1", "b1");
    // A save killed before its link: a partial generation and a link temp.
    fs::create_directories(t.path() / ".item.gen" / "0000000002");
    write_text(t.path() / ".item.gen" / "0000000002" / "a.txt", "a2 half");
    fs::create_symlink(".item.gen/0000000002", t.path() / ".item.link-99999");
    const state::LoadedItem r = state::load_item(t.path(), "item", two_files(), {});
    ASSERT_TRUE(r.verified);
    EXPECT_EQ(read_text(t.path() / "item" / "a.txt"), "a1");
    EXPECT_EQ(generations(t.path(), "item"), 1);
    EXPECT_FALSE(fs::exists(fs::symlink_status(t.path() / ".item.link-99999")));
    // The next save takes generation 2 afresh.
    save_two(t.path(), "a2", "b2");
    EXPECT_EQ(fs::canonical(t.path() / "item").filename(), "0000000002");
}

TEST(StateStore, AFailedSaveNamesTheFileKeepsTheOldVersionAndIsReported) {
    TempDir t;
    save_two(t.path(), "a1", "b1");
    // A writer that fails half-way (as save_exr does on a full disk).
    const auto failing = state::StateFile{"b.txt", [](const fs::path& p) {
                                              write_text(p, "half");
                                              throw RuntimeError(p.string() + ": cannot write: No space left on device");
                                          }};
    try {
        state::save_item(t.path(), "item", {state::text_file("a.txt", "a2"), failing});
        FAIL() << "the save did not fail";
    } catch (const state::SaveError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("cannot save " + (t.path() / "item").string()), std::string::npos) << what;
        EXPECT_NE(what.find("b.txt"), std::string::npos) << what;
        EXPECT_NE(what.find("No space left on device"), std::string::npos) << what;
    }
    ASSERT_TRUE(state::last_save_error());
    EXPECT_NE(state::last_save_error()->find("b.txt"), std::string::npos);
    EXPECT_TRUE(state::load_item(t.path(), "item", two_files(), {}).verified);
    EXPECT_EQ(read_text(t.path() / "item" / "a.txt"), "a1");
    EXPECT_EQ(generations(t.path(), "item"), 1);  // the failed generation removed
    save_two(t.path(), "a3", "b3");
    // Saved since: no longer reported (another test's failure may be, in the same process).
    EXPECT_EQ(state::last_save_error().value_or("").find((t.path() / "item").string()), std::string::npos);
}

TEST(StateStore, ASaveIntoAnUnusableDirectoryFailsNamingIt) {
    TempDir t;
    write_text(t.path() / "file", "x");
    EXPECT_THROW(state::save_item(t.path() / "file", "item", {state::text_file("a.txt", "a")}), state::SaveError);
    ASSERT_TRUE(state::last_save_error());
    EXPECT_NE(state::last_save_error()->find((t.path() / "file").string()), std::string::npos);
    EXPECT_THROW(state::save_item(t.path(), "../up", {state::text_file("a.txt", "a")}), state::SaveError);
}

// The appliance's own items.
TEST(SceneState, ACommittedSceneLoadsAfterARestartAndADamagedOneIsSetAside) {
    TempDir t;
    const fs::path scene = t.path() / "scene";
    Logged logged;
    EXPECT_FALSE(last_scene_env(scene, logged.log()));  // a new appliance: the grey room
    const fs::path env = scene_capture_path(scene, false);
    EXPECT_NE(env.parent_path(), scene);
    save_exr(env.parent_path() / kSceneCoverage, scene_coverage(7));
    save_exr(env, scene_env(7));
    const HdrImage taken = take_captured_scene(scene, false, logged.log());
    EXPECT_EQ(taken.data(), scene_env(7).data());
    const std::optional<HdrImage> last = load_last_scene(scene, logged.log());
    ASSERT_TRUE(last);
    EXPECT_EQ(last->data(), scene_env(7).data());
    EXPECT_EQ(load_exr(scene / kSceneCoverage).image.data(), scene_coverage(7).data());
    ASSERT_EQ(logged.lines.size(), 1u) << logged.all();
    EXPECT_NE(logged.lines[0].find("the last scene (0000000001, 64x32) verified and loaded"), std::string::npos) << logged.lines[0];
    logged.lines.clear();

    // One flipped byte in the map: detected, set aside, the grey room.
    const fs::path gen = fs::canonical(scene);
    std::string bytes = read_text(gen / kSceneEnv);
    bytes[bytes.size() / 2] = char(bytes[bytes.size() / 2] ^ 1);
    write_text(gen / kSceneEnv, bytes);
    EXPECT_FALSE(load_last_scene(scene, logged.log()));
    ASSERT_EQ(logged.lines.size(), 1u);
    EXPECT_NE(logged.lines[0].find("env.exr: checksum"), std::string::npos) << logged.lines[0];
    EXPECT_EQ(set_asides(t.path()).size(), 1u);
}

TEST(SceneState, AReplayWritesItsOwnDirectoryAsBefore) {
    TempDir t;
    const fs::path env = scene_capture_path(t.path(), true);
    EXPECT_EQ(env, t.path() / kSceneEnv);
    save_exr(env, scene_env(3));
    EXPECT_EQ(take_captured_scene(t.path(), true, {}).data(), scene_env(3).data());
    EXPECT_FALSE(state::is_store_item(t.path()));
}

TEST(CalibrationState, SavedVerifiedAndADamagedOneGivesNone) {
    TempDir t;
    capture::save_state_calibration(t.path(), calibration_version(5));
    Logged logged;
    std::optional<capture::CameraCalibration> c = capture::load_state_calibration(t.path(), logged.log());
    ASSERT_TRUE(c);
    EXPECT_EQ(c->time_offset_s, 5);
    // glint calibrate --calibration <state>/calibration.json keeps it a checksummed item.
    capture::save_calibration(t.path() / capture::kStateCalibrationName, calibration_version(6));
    EXPECT_TRUE(state::is_store_item(t.path() / capture::kStateCalibrationName));
    EXPECT_EQ(capture::load_state_calibration(t.path(), logged.log())->time_offset_s, 6);
    EXPECT_TRUE(logged.lines.empty()) << logged.all();
    // Truncated: set aside, no calibration.
    fs::resize_file(fs::canonical(t.path() / capture::kStateCalibrationName), 100);
    EXPECT_FALSE(capture::load_state_calibration(t.path(), logged.log()));
    ASSERT_EQ(logged.lines.size(), 1u);
    EXPECT_NE(logged.lines[0].find("calibration.json: 100 bytes"), std::string::npos) << logged.lines[0];
    // A technician's copy (no checksum) is used if it parses.
    write_text(t.path() / capture::kStateCalibrationName, capture::calibration_to_json(calibration_version(9)));
    EXPECT_EQ(capture::load_state_calibration(t.path(), logged.log())->time_offset_s, 9);
    EXPECT_NE(logged.lines.back().find("loaded unverified"), std::string::npos);
}

TEST(CalibrationState, GlintRunsReadOfTheStateCalibrationVerifiesIt) {
    // glint run reads <state.dir>/calibration.json with load_calibration: a flipped digit that
    // still parses must not become the camera model.
    TempDir t;
    capture::save_state_calibration(t.path(), calibration_version(5));
    const fs::path file = t.path() / capture::kStateCalibrationName;
    EXPECT_EQ(capture::load_calibration(file).time_offset_s, 5);
    std::string text = read_text(file);
    const std::size_t at = text.find("\"time_offset_s\": 5");
    ASSERT_NE(at, std::string::npos) << text;
    text[at + 17] = '6';
    write_text(fs::canonical(file), text);
    EXPECT_EQ(capture::calibration_from_json(text, "x").time_offset_s, 6);  // it does parse
    try {
        (void)capture::load_calibration(file);
        FAIL() << "the damaged calibration was read";
    } catch (const InputError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("did not verify: calibration.json: checksum"), std::string::npos) << what;
        EXPECT_NE(what.find("set aside in " + (t.path() / "corrupt").string()), std::string::npos) << what;
    }
    EXPECT_EQ(set_asides(t.path()).size(), 1u);
    // Plain files (sessions, glint calibrate's elsewhere) are read as before.
    write_text(t.path() / "plain.json", capture::calibration_to_json(calibration_version(3)));
    EXPECT_EQ(capture::load_calibration(t.path() / "plain.json").time_offset_s, 3);
}

TEST(PinLockState, ADamagedLockFileIsSetAsideAndLocks) {
    TempDir t;
    const fs::path file = t.path() / kPinLockItem;
    ui::MaintenanceSection policy;
    policy.pin_hash = kFastPinHash;
    {
        ui::PinLock lock(policy, file, {}, [] { return std::int64_t(1'000'000'000'000); }, kBootId);
        EXPECT_EQ(lock.try_pin("0000"), ui::PinResult::Rejected);
    }
    EXPECT_TRUE(state::is_store_item(file));
    EXPECT_EQ(read_text(file), pin_lock_text(1));
    // A flipped byte that still parses ("failures 1" -> "failures 0"): only the checksum sees it.
    std::string text = read_text(file);
    text[text.find("failures 1") + 9] = '0';
    write_text(fs::canonical(file), text);
    std::vector<ui::PinEvent> events;
    ui::PinLock lock(policy, file, [&](const ui::PinEvent& e) { events.push_back(e); },
                     [] { return std::int64_t(2'000'000'000'000); }, kBootId);
    EXPECT_TRUE(lock.locked());
    ASSERT_FALSE(events.empty());
    EXPECT_EQ(events[0].kind, ui::PinEvent::Kind::StateError);
    EXPECT_NE(events[0].detail.find("checksum"), std::string::npos) << events[0].detail;
    EXPECT_NE(events[0].detail.find("set aside in"), std::string::npos) << events[0].detail;
    EXPECT_EQ(set_asides(t.path()).size(), 1u);
    EXPECT_TRUE(state::is_store_item(file));  // the lock's state saved again, checksummed
}

TEST(StateStore, OnlyTheNewestSetsAsideAreKept) {
    // A file damaged at every start must not fill the state partition: 20 faults leave the
    // newest kCorruptKept sets, the last one among them.
    TempDir t;
    fs::path last;
    for (int k = 0; k < 20; ++k) {
        save_two(t.path(), "a " + std::to_string(k), "b");
        last = state::set_aside(t.path(), "item", "fault " + std::to_string(k));
    }
    EXPECT_EQ(state::corrupt_sets(t.path()), state::kCorruptKept);
    EXPECT_EQ(set_asides(t.path()).size(), state::kCorruptKept);
    ASSERT_TRUE(fs::is_directory(last));
    EXPECT_NE(read_text(last / "REASON.txt").find("fault 19"), std::string::npos);
    // The oldest went: no REASON.txt of the first four faults is left.
    for (const fs::path& set : set_asides(t.path()))
        for (int k = 0; k < 4; ++k)
            EXPECT_EQ(read_text(set / "REASON.txt").find("fault " + std::to_string(k) + "\n"), std::string::npos) << set;
}

}  // namespace
}  // namespace glint::faults
