// Saves that the system refuses (issue 18 part 1): a full disk and a read-only state directory.
// Every save must fail with an error naming the file and the system's reason, be reported
// (state::last_save_error(), the PIN lock's StateError), leave the old version of every item
// intact and loadable, and leave no half-written generation behind.
//
// How the faults are made (we run as root, so permission bits do not stop us):
//   full disk:  a 512 KiB tmpfs mounted on the state directory in a private mount namespace,
//               then filled (ENOSPC); where mounting is not allowed, RLIMIT_FSIZE with SIGXFSZ
//               ignored (EFBIG: "File too large", only files larger than the limit fail);
//   read-only:  the state directory bind-mounted onto itself read-only (EROFS); where mounting is
//               not allowed, the saves run as user 65534 in a root-owned 0755 directory (EACCES).
// Each runs in a child process (this program run again, main below: the mounts die with it). The
// mechanism used is printed; none available fails the test saying why.
#include <errno.h>
#include <sched.h>
#include <signal.h>
#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>

#include "appliance/capture/calibration_io.hpp"
#include "appliance/core/exr_io.hpp"
#include "appliance/core/scene_state.hpp"
#include "appliance/core/state_store.hpp"
#include "appliance/ui/pin_lock.hpp"
#include "tests/faults/faults_support.hpp"
#include "tests/faults/state_versions.hpp"

namespace glint::faults {
int disk_full_child(const std::filesystem::path& base);
int read_only_child(const std::filesystem::path& base);
namespace {

namespace fs = std::filesystem;

ui::MaintenanceSection fast_policy() {
    ui::MaintenanceSection m;
    m.pin_hash = kFastPinHash;
    m.max_attempts = 1 << 30;
    return m;
}

struct Child {
    fs::path dir;
    std::string problems;
    std::string mechanism;
    void problem(const std::string& p) { problems += "  " + p + "\n"; }
};

// The scene as the kiosk saves it, then the other items.
void save_version(Child& c, std::uint64_t v, ui::PinLock& lock) {
    const fs::path env = scene_capture_path(c.dir / kSceneItem, false);
    save_exr(env.parent_path() / kSceneCoverage, scene_coverage(v));
    save_exr(env, scene_env(v));
    std::string logged;
    (void)take_captured_scene(c.dir / kSceneItem, false, [&](const std::string& l) { logged += l; });
    if (!logged.empty()) c.problem("scene " + std::to_string(v) + " not saved: " + logged);
    capture::save_state_calibration(c.dir, calibration_version(v));
    state::save_item(c.dir, kSettingsItem, {state::text_file(kSettingsItem, settings_version(v))});
    while (std::uint64_t(lock.failures()) < v) (void)lock.try_pin("0000");
}

// Expects `save` to throw state::SaveError naming `names` and saying `reason`.
void expect_refused(Child& c, const std::string& what, const std::string& names, const std::string& reason,
                    const std::function<void()>& save) {
    try {
        save();
        c.problem(what + ": the save did not fail");
        return;
    } catch (const state::SaveError& e) {
        const std::string m = e.what();
        if (m.find(names) == std::string::npos || m.find(reason) == std::string::npos)
            c.problem(what + ": the error does not name " + names + " and say " + reason + ": " + m);
        const std::optional<std::string> shown = state::last_save_error();
        if (!shown || *shown != m) c.problem(what + ": last_save_error() is not the error: " + shown.value_or("(none)"));
        std::fprintf(stderr, "refused as expected: %s\n", m.c_str());
    } catch (const std::exception& e) {
        c.problem(what + ": not a state::SaveError: " + e.what());
    }
}

// The saves of version 2 refused; every item still version 1, whole; nothing left half-written.
void expect_all_refused(Child& c, const std::string& reason, bool small_files_fail, ui::PinLock& lock) {
    // The scene: a map much larger than the old one.
    HdrImage big(256, 128);
    std::mt19937 rng(7);
    for (float& x : big.data()) x = std::uniform_real_distribution<float>(0, 100)(rng);
    expect_refused(c, "scene", (c.dir / kSceneItem).string(), reason, [&] {
        state::save_item(c.dir, kSceneItem,
                         {{kSceneEnv, [&](const fs::path& p) { save_exr(p, big); }},
                          {kSceneCoverage, [&](const fs::path& p) { save_exr(p, scene_coverage(2)); }}});
    });
    expect_refused(c, "calibration", capture::kStateCalibrationName, reason,
                   [&] { capture::save_state_calibration(c.dir, calibration_version(2)); });
    if (small_files_fail) {
        expect_refused(c, "settings", kSettingsItem, reason, [&] {
            state::save_item(c.dir, kSettingsItem, {state::text_file(kSettingsItem, settings_version(2))});
        });
        // The PIN lock reports its failed save and keeps the count in memory.
        std::vector<ui::PinEvent> events;
        ui::PinLock reporting(fast_policy(), c.dir / kPinLockItem, [&](const ui::PinEvent& e) { events.push_back(e); },
                              ui::monotonic_now_ns, kBootId);
        (void)reporting.try_pin("0000");
        bool reported = false;
        for (const ui::PinEvent& e : events)
            if (e.kind == ui::PinEvent::Kind::StateError && e.detail.find(kPinLockItem) != std::string::npos &&
                e.detail.find(reason) != std::string::npos)
                reported = true;
        if (!reported) c.problem("PIN lock: no StateError naming " + std::string(kPinLockItem) + " and saying " + reason);
        if (reporting.failures() != 2) c.problem("PIN lock: the count in memory is " + std::to_string(reporting.failures()));
        // The kiosk's own path: the capture's files are in staging, the commit cannot be saved;
        // the visitor still gets the map, the failure is logged and shown.
        (void)lock;
    }
    std::string found_problems;
    const ItemVersions found = read_versions(c.dir, found_problems, {});
    if (!found_problems.empty()) c.problem("after the refused saves: " + found_problems);
    if (found.scene != 1u || found.calibration != 1u || found.settings != 1u || found.pin != 1u)
        c.problem("after the refused saves an item is not version 1 (scene " + std::to_string(found.scene.value_or(0)) +
                  ", calibration " + std::to_string(found.calibration.value_or(0)) + ", settings " +
                  std::to_string(found.settings.value_or(0)) + ", PIN " + std::to_string(found.pin.value_or(0)) + ")");
    for (const auto& e : fs::directory_iterator(c.dir)) {
        const std::string name = e.path().filename().string();
        if (name.size() > 4 && name.compare(name.size() - 4, 4, ".gen") == 0) {
            int n = 0;
            for (const auto& g : fs::directory_iterator(e.path())) (void)g, ++n;
            if (n != 1) c.problem(name + ": " + std::to_string(n) + " generations after the refused saves");
        }
    }
}

int finish(Child& c, const fs::path& base) {
    std::error_code ec;
    fs::remove_all(base, ec);  // the death test's child made its own directory; nobody else removes it
    if (!c.problems.empty()) {
        std::fprintf(stderr, "mechanism: %s\nproblems:\n%s", c.mechanism.c_str(), c.problems.c_str());
        return 1;
    }
    std::fprintf(stderr, "saves refused, old versions intact (mechanism: %s)\n", c.mechanism.c_str());
    return 0;
}

bool private_mounts(std::string& why) {
    // To run the other mechanisms where mounts work (ctest runs them so too: faults.save_faults_without_mounts).
    if (std::getenv("GLINT_FAULTS_NO_MOUNTS")) {
        why = "GLINT_FAULTS_NO_MOUNTS is set";
        return false;
    }
    if (::unshare(CLONE_NEWNS) != 0) {
        why = std::string("unshare(CLONE_NEWNS): ") + std::strerror(errno);
        return false;
    }
    if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) {
        why = std::string("mount --make-rprivate /: ") + std::strerror(errno);
        return false;
    }
    return true;
}

int disk_full_child_impl(const fs::path& base) {
    Child c;
    c.dir = base / "state";
    fs::create_directories(c.dir);
    std::string why;
    bool tmpfs = private_mounts(why);
    if (tmpfs && ::mount("glint-faults", c.dir.c_str(), "tmpfs", MS_NOSUID | MS_NODEV, "size=512k,mode=0755") != 0) {
        why = std::string("mount -t tmpfs: ") + std::strerror(errno);
        tmpfs = false;
    }
    c.mechanism = tmpfs ? "a 512 KiB tmpfs filled up (ENOSPC)" : "RLIMIT_FSIZE 4096 (EFBIG), because " + why;
    const std::string reason = tmpfs ? "No space left on device" : "File too large";
    ui::PinLock lock(fast_policy(), c.dir / kPinLockItem, {}, ui::monotonic_now_ns, kBootId);
    save_version(c, 1, lock);
    // The kiosk's scene whose capture is written before the disk fills: committed below.
    const fs::path staged = scene_capture_path(c.dir / kSceneItem, false);
    save_exr(staged.parent_path() / kSceneCoverage, scene_coverage(5));
    save_exr(staged, scene_env(5));
    const fs::path filler = c.dir / "filler";
    if (tmpfs) {
        // Fill every byte left.
        FILE* f = std::fopen(filler.c_str(), "wb");
        std::vector<char> chunk(4096, 'x');
        while (f && std::fwrite(chunk.data(), 1, chunk.size(), f) == chunk.size() && std::fflush(f) == 0) {
        }
        if (f) std::fclose(f);
    } else {
        ::signal(SIGXFSZ, SIG_IGN);
        // The soft limit only: raising it again needs no CAP_SYS_RESOURCE.
        rlimit limit{};
        ::getrlimit(RLIMIT_FSIZE, &limit);
        limit.rlim_cur = 4096;
        if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) c.problem(std::string("setrlimit: ") + std::strerror(errno));
        if (capture::calibration_to_json(calibration_version(2)).size() <= 4096) c.problem("the calibration fits in 4096 bytes");
    }
    expect_all_refused(c, reason, tmpfs, lock);
    if (tmpfs) {
        std::string logged;
        const HdrImage shown = take_captured_scene(c.dir / kSceneItem, false, [&](const std::string& l) { logged += l; });
        if (shown.data() != scene_env(5).data()) c.problem("take_captured_scene: not the captured map");
        if (logged.find("the scene was not saved") == std::string::npos || logged.find(reason) == std::string::npos)
            c.problem("take_captured_scene: the failed commit was not logged with its reason: " + logged);
        if (!state::last_save_error() || state::last_save_error()->find(reason) == std::string::npos)
            c.problem("take_captured_scene: last_save_error() does not hold the failed commit");
        const std::optional<HdrImage> last = load_last_scene(c.dir / kSceneItem, {});
        if (!last || last->data() != scene_env(1).data()) c.problem("after the failed commit the last scene is not version 1");
        fs::remove(filler);
    } else {
        rlimit limit{};
        ::getrlimit(RLIMIT_FSIZE, &limit);
        limit.rlim_cur = limit.rlim_max;
        if (::setrlimit(RLIMIT_FSIZE, &limit) != 0) c.problem(std::string("setrlimit back: ") + std::strerror(errno));
    }
    // Space again: the next saves work and clear the error.
    save_version(c, 3, lock);
    std::string found_problems;
    const ItemVersions found = read_versions(c.dir, found_problems, {});
    if (!found_problems.empty() || found.scene != 3u || found.calibration != 3u || found.settings != 3u || found.pin != 3u)
        c.problem("with space again, version 3 did not save whole: " + found_problems);
    if (state::last_save_error()) c.problem("last_save_error() still set after good saves: " + *state::last_save_error());
    return finish(c, base);
}

int read_only_child_impl(const fs::path& base) {
    Child c;
    c.dir = base / "state";
    fs::create_directories(c.dir);
    ui::PinLock lock(fast_policy(), c.dir / kPinLockItem, {}, ui::monotonic_now_ns, kBootId);
    save_version(c, 1, lock);
    std::string why;
    bool bind = private_mounts(why);
    if (bind && (::mount(c.dir.c_str(), c.dir.c_str(), nullptr, MS_BIND, nullptr) != 0 ||
                 ::mount(nullptr, c.dir.c_str(), nullptr, MS_BIND | MS_REMOUNT | MS_RDONLY, nullptr) != 0)) {
        why = std::string("mount --bind -o ro: ") + std::strerror(errno);
        bind = false;
    }
    std::string reason = "Read-only file system";
    if (bind) {
        c.mechanism = "a read-only bind mount (EROFS)";
    } else {
        c.mechanism = "user 65534 in a root-owned 0755 directory (EACCES), because " + why;
        reason = "Permission denied";
        fs::permissions(base, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                  fs::perms::others_read | fs::perms::others_exec);
        // Root kept as the saved id, to clean up afterwards.
        if (::setresgid(65534, 65534, 0) != 0 || ::setresuid(65534, 65534, 0) != 0) {
            c.problem(std::string("no mechanism: cannot become user 65534: ") + std::strerror(errno));
            return finish(c, base);
        }
    }
    expect_all_refused(c, reason, true, lock);
    {
        // A visitor's scan now: the capture goes to a temporary directory, the visitor gets the
        // map, the commit fails and is logged with its reason, the last scene stays.
        const fs::path staged = scene_capture_path(c.dir / kSceneItem, false);
        if (staged.string().rfind(c.dir.string(), 0) == 0) c.problem("the capture was sent into the read-only directory: " + staged.string());
        save_exr(staged.parent_path() / kSceneCoverage, scene_coverage(5));
        save_exr(staged, scene_env(5));
        std::string logged;
        const HdrImage shown = take_captured_scene(c.dir / kSceneItem, false, [&](const std::string& l) { logged += l; });
        if (shown.data() != scene_env(5).data()) c.problem("take_captured_scene: not the captured map");
        if (logged.find("the scene was not saved") == std::string::npos || logged.find(reason) == std::string::npos)
            c.problem("take_captured_scene: the failed commit was not logged with its reason: " + logged);
        else std::fprintf(stderr, "logged as expected: %s\n", logged.c_str());
        const std::optional<HdrImage> last = load_last_scene(c.dir / kSceneItem, {});
        if (!last || last->data() != scene_env(1).data()) c.problem("after the failed commit the last scene is not version 1");
        std::error_code ec;
        fs::remove_all(staged.parent_path(), ec);  // the temporary directory is not the test's to leave
    }
    if (bind) {
        // Writable again: the saves work.
        if (::umount(c.dir.c_str()) != 0) c.problem(std::string("umount: ") + std::strerror(errno));
        save_version(c, 3, lock);
        std::string found_problems;
        const ItemVersions found = read_versions(c.dir, found_problems, {});
        if (!found_problems.empty() || found.scene != 3u || found.pin != 3u)
            c.problem("writable again, version 3 did not save whole: " + found_problems);
        return finish(c, base);
    }
    if (::setresuid(0, 0, 0) != 0 || ::setresgid(0, 0, 0) != 0) c.problem(std::string("cannot become root again: ") + std::strerror(errno));
    save_version(c, 3, lock);
    std::string found_problems;
    const ItemVersions found = read_versions(c.dir, found_problems, {});
    if (!found_problems.empty() || found.scene != 3u || found.pin != 3u)
        c.problem("as root again, version 3 did not save whole: " + found_problems);
    return finish(c, base);
}

// Runs this test program again as `--child=KIND DIR` (main below): a fresh process, so that no
// OpenEXR thread pool is copied by a fork, whose mounts end with it. Returns its exit status and
// everything it wrote.
std::pair<int, std::string> run_child(const std::string& kind, const fs::path& dir) {
    int fds[2];
    if (::pipe(fds) != 0) return {-1, "pipe failed"};
    const pid_t pid = ::fork();
    if (pid == 0) {
        ::dup2(fds[1], 1);
        ::dup2(fds[1], 2);
        ::close(fds[0]);
        const std::string arg = "--child=" + kind;
        ::execl("/proc/self/exe", "glint_faults_tests", arg.c_str(), dir.c_str(), static_cast<char*>(nullptr));
        _exit(127);
    }
    ::close(fds[1]);
    std::string out;
    char buffer[4096];
    ssize_t n;
    while ((n = ::read(fds[0], buffer, sizeof buffer)) > 0) out.append(buffer, std::size_t(n));
    ::close(fds[0]);
    int status = 0;
    ::waitpid(pid, &status, 0);
    return {WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status), out};
}

TEST(SaveFaults, AFullDiskRefusesEverySaveNamingTheFileAndKeepsTheOldVersions) {
    TempDir t;
    const auto [status, out] = run_child("disk-full", t.path());
    std::printf("%s", out.c_str());
    EXPECT_EQ(status, 0) << out;
    EXPECT_NE(out.find("saves refused, old versions intact"), std::string::npos) << out;
}

TEST(SaveFaults, AReadOnlyStateDirectoryRefusesEverySaveAndKeepsTheOldVersions) {
    TempDir t;
    const auto [status, out] = run_child("read-only", t.path());
    std::printf("%s", out.c_str());
    EXPECT_EQ(status, 0) << out;
    EXPECT_NE(out.find("saves refused, old versions intact"), std::string::npos) << out;
}

}  // namespace

int disk_full_child(const std::filesystem::path& base) { return disk_full_child_impl(base); }
int read_only_child(const std::filesystem::path& base) { return read_only_child_impl(base); }

}  // namespace glint::faults

// The tests, or one fault's child (run_child above).
int main(int argc, char** argv) {
    if (argc == 3 && std::string(argv[1]).rfind("--child=", 0) == 0) {
        const std::string kind = std::string(argv[1]).substr(8);
        try {
            if (kind == "disk-full") return glint::faults::disk_full_child(argv[2]);
            if (kind == "read-only") return glint::faults::read_only_child(argv[2]);
        } catch (const std::exception& e) {
            std::fprintf(stderr, "the %s child failed: %s\n", kind.c_str(), e.what());
            return 3;
        }
        std::fprintf(stderr, "unknown child %s\n", kind.c_str());
        return 2;
    }
    ::testing::InitGoogleTest(&argc, argv);
    return RUN_ALL_TESTS();
}
