// The maintenance PIN (appliance/ui/pin_lock.hpp): yescrypt hashes, and the lock-out after
// max_attempts wrong PINs that holds for lockout_s across restarts and reboots, on a fake clock.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "appliance/core/errors.hpp"
#include "appliance/ui/pin_lock.hpp"

namespace fs = std::filesystem;
using namespace glint::ui;
using Kind = PinEvent::Kind;

namespace {

constexpr std::int64_t kSecond = 1'000'000'000;

// Made outside this code: Python's crypt.crypt("1234", "$y$j9T$F5Jx5fExrKuPp53xLKQ..1").
const std::string kHash1234 = "$y$j9T$F5Jx5fExrKuPp53xLKQ..1$Ep4SUX.oXxnq/KKEBY/E3tIknDNDS9Tu.RwGhF8ZCzA";

class TempDir {
public:
    TempDir() {
        char tmpl[] = "/tmp/glint-pin-XXXXXX";
        path_ = ::mkdtemp(tmpl);
    }
    ~TempDir() { fs::remove_all(path_); }
    const fs::path& path() const { return path_; }

private:
    fs::path path_;
};

std::string read_text(const fs::path& p) {
    std::ifstream in(p);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

// A PinLock on a clock the test moves, recording every event.
struct Rig {
    explicit Rig(const fs::path& state_file, std::string boot = "boot-a", std::int64_t start_ns = 1000 * kSecond)
        : now(start_ns) {
        policy.pin_hash = kHash1234;
        lock = std::make_unique<PinLock>(
            policy, state_file, [this](const PinEvent& e) { events.push_back(e); }, [this] { return now; }, std::move(boot));
    }
    std::vector<Kind> kinds() const {
        std::vector<Kind> out;
        for (const auto& e : events) out.push_back(e.kind);
        return out;
    }
    std::int64_t now;
    MaintenanceSection policy;
    std::vector<PinEvent> events;
    std::unique_ptr<PinLock> lock;
};

}  // namespace

TEST(PinHash, HashesWithYescryptAndVerifies) {
    const std::string h = hash_pin("482916");
    EXPECT_EQ(h.rfind("$y$", 0), 0u) << h;
    EXPECT_TRUE(verify_pin("482916", h));
    EXPECT_FALSE(verify_pin("482917", h));
    EXPECT_FALSE(verify_pin("", h));
    EXPECT_FALSE(pin_hash_problem(h).has_value());
    // A random salt each time: the same PIN never gives the same hash.
    EXPECT_NE(hash_pin("482916"), h);
}

TEST(PinHash, VerifiesAHashMadeElsewhere) {
    EXPECT_TRUE(verify_pin("1234", kHash1234));
    EXPECT_FALSE(verify_pin("1235", kHash1234));
    EXPECT_FALSE(verify_pin("12345", kHash1234));
}

// A technician without the maintenance menu makes a hash with `openssl passwd -6` (SHA-512
// crypt, in every Debian): it is accepted and verifies. This one is
// `openssl passwd -6 -salt glintsalt 2468`.
TEST(PinHash, AcceptsAnOpensslSha512Hash) {
    const std::string sha512 =
        "$6$glintsalt$bVKSipYXNX9hhWBpXw1i5j8lgHCDsSrZ0M2m4dJ9e8HBBL62kdO13DTR/HfM3te4h3HxZpiOFr9G.YkbyLvv40";
    EXPECT_EQ(pin_hash_problem(sha512), std::nullopt);
    EXPECT_TRUE(verify_pin("2468", sha512));
    EXPECT_FALSE(verify_pin("2469", sha512));
}

TEST(PinHash, MalformedHashesMatchNothing) {
    EXPECT_FALSE(verify_pin("1234", ""));
    EXPECT_FALSE(verify_pin("1234", "1234"));
    EXPECT_FALSE(verify_pin("1234", "*0"));
    // The setting alone would be completed by crypt_r; it must not match anything either.
    EXPECT_FALSE(verify_pin("1234", "$y$j9T$F5Jx5fExrKuPp53xLKQ..1"));
    EXPECT_FALSE(verify_pin("1234", kHash1234.substr(0, kHash1234.size() - 1)));
}

TEST(PinHash, OnlyFourToSixteenDigits) {
    EXPECT_NO_THROW(hash_pin("0000"));
    EXPECT_NO_THROW(hash_pin("1234567890123456"));
    EXPECT_THROW(hash_pin("123"), glint::InputError);
    EXPECT_THROW(hash_pin("12345678901234567"), glint::InputError);
    EXPECT_THROW(hash_pin("12a4"), glint::InputError);
    EXPECT_THROW(hash_pin("12 34"), glint::InputError);
}

TEST(PinLock, FiveWrongPinsLockForFiveMinutes) {
    TempDir dir;
    Rig rig(dir.path() / "pin-lock");
    for (int k = 1; k <= 4; ++k) {
        EXPECT_EQ(rig.lock->try_pin("0000"), PinResult::Rejected) << k;
        EXPECT_EQ(rig.lock->failures(), k);
        rig.now += 2 * kSecond;
    }
    EXPECT_FALSE(rig.lock->locked());
    EXPECT_EQ(rig.lock->try_pin("9999"), PinResult::LockedOut);
    EXPECT_TRUE(rig.lock->locked());
    EXPECT_DOUBLE_EQ(rig.lock->remaining_s(), 300.0);

    // While locked even the right PIN is refused, unchecked.
    rig.events.clear();
    rig.now += 299 * kSecond;
    EXPECT_EQ(rig.lock->try_pin("1234"), PinResult::LockedOut);
    EXPECT_EQ(rig.kinds(), (std::vector<Kind>{Kind::Attempt, Kind::Refused}));
    EXPECT_NEAR(rig.events.back().locked_for_s, 1.0, 1e-9);
    rig.now += kSecond - 1;
    EXPECT_TRUE(rig.lock->locked());

    // At 300 s the lock ends, the count starts again, and the right PIN opens the menu.
    rig.events.clear();
    rig.now += 1;
    EXPECT_FALSE(rig.lock->locked());
    EXPECT_EQ(rig.lock->failures(), 0);
    EXPECT_EQ(rig.kinds(), (std::vector<Kind>{Kind::LockExpired}));
    EXPECT_EQ(rig.lock->try_pin("1234"), PinResult::Accepted);
}

TEST(PinLock, ReportsEveryAttemptSuccessFailureAndLockOut) {
    TempDir dir;
    Rig rig(dir.path() / "pin-lock");
    rig.lock->try_pin("1111");
    rig.lock->try_pin("1234");
    for (int k = 0; k < 5; ++k) rig.lock->try_pin("1111");
    EXPECT_EQ(rig.kinds(), (std::vector<Kind>{Kind::Attempt, Kind::Failure, Kind::Attempt, Kind::Success,  //
                                              Kind::Attempt, Kind::Failure, Kind::Attempt, Kind::Failure,  //
                                              Kind::Attempt, Kind::Failure, Kind::Attempt, Kind::Failure,  //
                                              Kind::Attempt, Kind::Failure, Kind::LockedOut}));
    // A success resets the count: the failure after it is the first again.
    EXPECT_EQ(rig.events[1].failures, 1);
    EXPECT_EQ(rig.events[5].failures, 1);
    EXPECT_EQ(rig.events[13].failures, 5);
    EXPECT_EQ(describe(rig.events[11]), "maintenance PIN: failure 4 of 5");
    EXPECT_EQ(describe(rig.events[14]), "maintenance PIN: locked out for 300 s (5 wrong PINs)");
    EXPECT_EQ(describe(rig.events[3]), "maintenance PIN: accepted, menu opened");
}

TEST(PinLock, LockSurvivesARestartWithTheTimeLeft) {
    TempDir dir;
    const fs::path file = dir.path() / "pin-lock";
    {
        Rig rig(file);
        for (int k = 0; k < 5; ++k) rig.lock->try_pin("0000");
        ASSERT_TRUE(rig.lock->locked());
    }
    // The same boot, 100 s later: 200 s remain.
    Rig again(file, "boot-a", 1100 * kSecond);
    EXPECT_TRUE(again.lock->locked());
    EXPECT_DOUBLE_EQ(again.lock->remaining_s(), 200.0);
    EXPECT_EQ(again.kinds(), (std::vector<Kind>{Kind::LockedOut}));
    EXPECT_EQ(again.lock->try_pin("1234"), PinResult::LockedOut);
    // 301 s after the lock-out started the lock is over.
    Rig later(file, "boot-a", 1301 * kSecond);
    EXPECT_FALSE(later.lock->locked());
    EXPECT_EQ(later.lock->try_pin("1234"), PinResult::Accepted);
}

TEST(PinLock, ARebootStartsALockOutInProgressAgain) {
    TempDir dir;
    const fs::path file = dir.path() / "pin-lock";
    {
        Rig rig(file);
        for (int k = 0; k < 5; ++k) rig.lock->try_pin("0000");
    }
    // After a reboot the monotonic clock is small again: neither "long past" nor the old end.
    Rig rebooted(file, "boot-b", 5 * kSecond);
    EXPECT_TRUE(rebooted.lock->locked());
    EXPECT_DOUBLE_EQ(rebooted.lock->remaining_s(), 300.0);
    // An unknown boot id counts as a reboot too.
    Rig unknown(file, "", 7 * kSecond);
    EXPECT_DOUBLE_EQ(unknown.lock->remaining_s(), 300.0);
}

TEST(PinLock, AStoredEndFarAwayIsCutToOneLockOut) {
    TempDir dir;
    const fs::path file = dir.path() / "pin-lock";
    std::ofstream(file) << "glint-pin-lock 1\nboot boot-a\nfailures 5\nlocked_until_ns 9000000000000000000\n";
    Rig rig(file);
    EXPECT_DOUBLE_EQ(rig.lock->remaining_s(), 300.0);
}

TEST(PinLock, TheCountSurvivesARestart) {
    TempDir dir;
    const fs::path file = dir.path() / "pin-lock";
    {
        Rig rig(file);
        for (int k = 0; k < 3; ++k) rig.lock->try_pin("0000");
    }
    Rig again(file, "boot-b");
    EXPECT_EQ(again.lock->failures(), 3);
    EXPECT_EQ(again.lock->try_pin("0000"), PinResult::Rejected);
    EXPECT_EQ(again.lock->try_pin("0000"), PinResult::LockedOut);
}

TEST(PinLock, ADamagedStateFileLocks) {
    TempDir dir;
    const fs::path file = dir.path() / "pin-lock";
    std::ofstream(file) << "glint-pin-lock 1\nboot boot-a\nfailures zero\n";
    Rig rig(file);
    EXPECT_TRUE(rig.lock->locked());
    EXPECT_EQ(rig.kinds(), (std::vector<Kind>{Kind::StateError, Kind::LockedOut}));
    EXPECT_EQ(rig.lock->try_pin("1234"), PinResult::LockedOut);
    // The file was rewritten whole: a restart reads it.
    EXPECT_EQ(read_text(file), "glint-pin-lock 1\nboot boot-a\nfailures 5\nlocked_until_ns 1300000000000\n");
    Rig again(file);
    EXPECT_EQ(again.kinds(), (std::vector<Kind>{Kind::LockedOut}));
}

TEST(PinLock, AnUnwritableStateFileIsReportedAndTheLockStillHolds) {
    TempDir dir;
    std::ofstream(dir.path() / "not-a-dir") << "x";
    Rig rig(dir.path() / "not-a-dir" / "pin-lock");
    for (int k = 0; k < 5; ++k) rig.lock->try_pin("0000");
    EXPECT_TRUE(rig.lock->locked());
    int state_errors = 0;
    for (const auto& e : rig.events) state_errors += e.kind == Kind::StateError;
    EXPECT_EQ(state_errors, 5);
}

TEST(PinLock, NoHashMeansNoPinOpensTheMenu) {
    TempDir dir;
    Rig rig(dir.path() / "pin-lock");
    MaintenanceSection none = rig.policy;
    none.pin_hash.clear();
    rig.lock->set_policy(none);
    EXPECT_EQ(rig.lock->try_pin("1234"), PinResult::Disabled);
    EXPECT_EQ(rig.lock->failures(), 0);
    EXPECT_EQ(rig.kinds(), (std::vector<Kind>{Kind::Attempt, Kind::Refused}));
}

TEST(PinLock, ANewPolicyAppliesLive) {
    TempDir dir;
    Rig rig(dir.path() / "pin-lock");
    EXPECT_EQ(rig.lock->try_pin("0000"), PinResult::Rejected);
    MaintenanceSection p = rig.policy;
    p.pin_hash = hash_pin("5555");
    p.max_attempts = 2;
    p.lockout_s = 60;
    rig.lock->set_policy(p);
    EXPECT_EQ(rig.lock->try_pin("1234"), PinResult::LockedOut);  // the old PIN, second failure of 2
    EXPECT_DOUBLE_EQ(rig.lock->remaining_s(), 60.0);
    rig.now += 60 * kSecond;
    EXPECT_EQ(rig.lock->try_pin("5555"), PinResult::Accepted);
}
