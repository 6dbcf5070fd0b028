// The maintenance PIN: libxcrypt's yescrypt, and the lock-out kept across restarts (pin_lock.hpp).
#include "appliance/ui/pin_lock.hpp"

#include <crypt.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>

#include "appliance/core/state_store.hpp"
#include "appliance/core/errors.hpp"

namespace glint::ui {
namespace {

constexpr std::size_t kMinPinDigits = 4, kMaxPinDigits = 16;
constexpr const char* kStateMagic = "glint-pin-lock";
constexpr int kStateVersion = 1;
constexpr const char* kNotAHash = "not a crypt(3) hash (a yescrypt hash starts with \"$y$\")";

// struct crypt_data is about 32 KiB: on the heap, zeroed as crypt_r requires on first use.
std::unique_ptr<crypt_data> new_crypt_data() {
    auto data = std::make_unique<crypt_data>();
    std::memset(data.get(), 0, sizeof(crypt_data));
    return data;
}

// crypt_r(phrase, setting): the hash, or "" on failure (libxcrypt returns a "*0"/"*1" failure
// token or NULL; neither can be a hash).
std::string crypt_string(const std::string& phrase, const std::string& setting) {
    auto data = new_crypt_data();
    const char* out = crypt_r(phrase.c_str(), setting.c_str(), data.get());
    if (!out || out[0] == '*') return {};
    return out;
}

// Compares every byte whatever the first difference, so the time taken says nothing about how
// much of the hash a guess matched. The lengths are public (they follow from the method).
bool equal_constant_time(const std::string& a, const std::string& b) {
    if (a.size() != b.size()) return false;
    unsigned char diff = 0;
    for (std::size_t k = 0; k < a.size(); ++k)
        diff = static_cast<unsigned char>(diff | (static_cast<unsigned char>(a[k]) ^ static_cast<unsigned char>(b[k])));
    return diff == 0;
}

std::string seconds_text(double s) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.0f s", std::ceil(s));
    return buf;
}

std::int64_t lockout_ns(const MaintenanceSection& policy) {
    return static_cast<std::int64_t>(std::llround(policy.lockout_s * 1e9));
}

}  // namespace

std::string hash_pin(const std::string& pin) {
    if (pin.size() < kMinPinDigits || pin.size() > kMaxPinDigits)
        throw InputError("PIN: " + std::to_string(pin.size()) + " digits; a PIN has " + std::to_string(kMinPinDigits) +
                         " to " + std::to_string(kMaxPinDigits));
    if (!std::all_of(pin.begin(), pin.end(), [](char c) { return c >= '0' && c <= '9'; }))
        throw InputError("PIN: only the digits 0-9 (the menu's keypad has no others)");
    char setting[CRYPT_GENSALT_OUTPUT_SIZE];
    // count 0: libxcrypt's default cost for yescrypt; rbytes NULL: random bytes from the OS.
    if (!crypt_gensalt_rn("$y$", 0, nullptr, 0, setting, sizeof setting))
        throw RuntimeError(std::string("PIN: crypt_gensalt_rn($y$) failed: ") + std::strerror(errno));
    std::string hash = crypt_string(pin, setting);
    if (hash.empty()) throw RuntimeError(std::string("PIN: crypt_r failed: ") + std::strerror(errno));
    return hash;
}

bool verify_pin(const std::string& pin, const std::string& hash) {
    if (hash.empty()) return false;
    const std::string computed = crypt_string(pin, hash);
    if (computed.empty()) return false;
    return equal_constant_time(computed, hash);
}

std::optional<std::string> pin_hash_problem(const std::string& hash) {
    // Any string of two salt characters is a traditional DES setting to crypt(3); a PIN typed
    // in place of its hash would read as one. Every method worth keeping starts with '$'.
    if (hash.empty() || hash.front() != '$') return std::string(kNotAHash);
    switch (crypt_checksalt(hash.c_str())) {
        case CRYPT_SALT_OK: break;
        case CRYPT_SALT_METHOD_LEGACY:
            return "a legacy crypt(3) method (DES, MD5, ...): make a yescrypt or SHA-512 one (mkpasswd -m yescrypt, "
                   "openssl passwd -6)";
        case CRYPT_SALT_METHOD_DISABLED: return "its crypt(3) method is disabled in this libxcrypt";
        case CRYPT_SALT_TOO_CHEAP: return "its crypt(3) cost is too low";
        default: return std::string(kNotAHash);
    }
    // A setting without its hash part ("$y$j9T$salt") passes crypt_checksalt: hash the empty
    // phrase with it; a complete hash gives a string of the same length and the same prefix up
    // to the last '$'.
    const std::string probe = crypt_string("", hash);
    const auto cut = hash.rfind('$');
    if (probe.empty() || probe.size() != hash.size() || cut == std::string::npos || probe.compare(0, cut, hash, 0, cut) != 0)
        return "an incomplete or malformed crypt(3) hash";
    return std::nullopt;
}

const char* pin_result_name(PinResult result) {
    switch (result) {
        case PinResult::Accepted: return "accepted";
        case PinResult::Rejected: return "rejected";
        case PinResult::LockedOut: return "locked out";
        case PinResult::Disabled: return "disabled";
    }
    return "?";
}

const char* pin_event_name(PinEvent::Kind kind) {
    switch (kind) {
        case PinEvent::Kind::Attempt: return "attempt";
        case PinEvent::Kind::Success: return "success";
        case PinEvent::Kind::Failure: return "failure";
        case PinEvent::Kind::LockedOut: return "locked out";
        case PinEvent::Kind::Refused: return "refused";
        case PinEvent::Kind::LockExpired: return "lock expired";
        case PinEvent::Kind::StateError: return "state error";
    }
    return "?";
}

std::string describe(const PinEvent& e) {
    std::string s = "maintenance PIN: ";
    switch (e.kind) {
        case PinEvent::Kind::Attempt: s += "attempt"; break;
        case PinEvent::Kind::Success: s += "accepted, menu opened"; break;
        case PinEvent::Kind::Failure:
            s += "failure " + std::to_string(e.failures) + " of " + std::to_string(e.max_attempts);
            break;
        case PinEvent::Kind::LockedOut: s += "locked out for " + seconds_text(e.locked_for_s); break;
        case PinEvent::Kind::Refused: s += "refused"; break;
        case PinEvent::Kind::LockExpired: s += "lock-out over"; break;
        case PinEvent::Kind::StateError: s += "state file"; break;
    }
    if (e.kind == PinEvent::Kind::Refused && e.locked_for_s > 0) s += ", locked for " + seconds_text(e.locked_for_s) + " more";
    if (!e.detail.empty()) s += " (" + e.detail + ")";
    return s;
}

std::int64_t monotonic_now_ns() {
    timespec ts{};
    ::clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::string current_boot_id() {
    std::ifstream in("/proc/sys/kernel/random/boot_id");
    std::string id;
    std::getline(in, id);
    return id;
}

PinLock::PinLock(const MaintenanceSection& policy, std::filesystem::path state_file, Reporter report, Clock now,
                 std::string boot_id)
    : policy_(policy), state_file_(std::move(state_file)), report_(std::move(report)), now_(std::move(now)),
      boot_id_(std::move(boot_id)) {
    load();
}

void PinLock::report(PinEvent::Kind kind, std::string detail) {
    if (!report_) return;
    PinEvent e;
    e.kind = kind;
    e.failures = failures_;
    e.max_attempts = policy_.max_attempts;
    if (locked_until_ns_ > 0) e.locked_for_s = std::max(0.0, static_cast<double>(locked_until_ns_ - now_()) * 1e-9);
    e.detail = std::move(detail);
    report_(e);
}

namespace {

struct StoredLock {
    std::string boot;
    int failures = -1;
    long long locked_until_ns = -1;
};

std::optional<StoredLock> parse_lock_state(const std::string& text) {
    std::istringstream in(text);
    std::string magic, boot_word, failures_word, until_word;
    int version = 0;
    StoredLock s;
    in >> magic >> version >> boot_word >> s.boot >> failures_word >> s.failures >> until_word >> s.locked_until_ns;
    const bool valid = in && magic == kStateMagic && version == kStateVersion && boot_word == "boot" &&
                       failures_word == "failures" && until_word == "locked_until_ns" && s.failures >= 0 &&
                       s.locked_until_ns >= 0;
    if (!valid) return std::nullopt;
    return s;
}

}  // namespace

void PinLock::load() {
    // The state file is a state item (core/state_store.hpp): checksummed when this build wrote it;
    // an older build's plain file is read if it parses.
    std::optional<StoredLock> stored;
    state::LoadPolicy policy;
    policy.files = {state_file_.filename().string()};
    policy.unverified = state::Unverified::Accept;
    policy.check = [&](const std::filesystem::path& file) {
        std::ifstream in(file);
        std::stringstream text;
        text << in.rdbuf();
        stored = parse_lock_state(text.str());
        if (!stored) throw RuntimeError("not a PIN lock state (" + std::string(kStateMagic) + " " +
                                        std::to_string(kStateVersion) + ", boot, failures, locked_until_ns)");
    };
    const std::filesystem::path dir = state_file_.parent_path().empty() ? std::filesystem::path(".") : state_file_.parent_path();
    const state::LoadedItem item = state::load_item(dir, state_file_.filename().string(), policy, {});
    if (!item.path && !item.fault) return;  // first start: nothing counted yet
    if (!item.path || !stored) {
        // Fail closed: a damaged file must not be a way to reset the count.
        failures_ = policy_.max_attempts;
        locked_until_ns_ = now_() + lockout_ns(policy_);
        report(PinEvent::Kind::StateError,
               state_file_.string() + " unreadable or damaged (" + item.defaults_because + ")" +
                   (item.set_aside.empty() ? std::string() : "; set aside in " + item.set_aside.string()) +
                   "; locking as after too many PINs");
        save();
        report(PinEvent::Kind::LockedOut, "state file damaged");
        return;
    }
    const std::string boot = stored->boot;
    const long long until = stored->locked_until_ns;
    failures_ = stored->failures;
    if (until == 0) return;
    // An unknown boot id (either side) counts as a reboot: the safe reading of "cannot tell".
    if (boot_id_.empty() || boot != boot_id_) {
        // The monotonic clock restarted with the boot: the old end means nothing now, and a
        // power cycle must not shorten the lock, so it runs again in full.
        locked_until_ns_ = now_() + lockout_ns(policy_);
        save();
        report(PinEvent::Kind::LockedOut, "lock-out in progress before a reboot, started again");
        return;
    }
    // A lock never runs longer than one lock-out from now: a file edited (or damaged into a
    // valid-looking form) to a far end, or a lockout_s shortened since, cannot lock for ever.
    locked_until_ns_ = std::min<std::int64_t>(until, now_() + lockout_ns(policy_));
    expire_if_due(now_());
    if (locked_until_ns_ > 0) report(PinEvent::Kind::LockedOut, "lock-out in progress before a restart, continued");
}

void PinLock::save() {
    std::ostringstream out;
    // "-" stands for an unknown boot id so that the file keeps its four fields.
    out << kStateMagic << ' ' << kStateVersion << "\nboot " << (boot_id_.empty() ? "-" : boot_id_) << "\nfailures "
        << failures_ << "\nlocked_until_ns " << locked_until_ns_ << "\n";
    try {
        const std::string name = state_file_.filename().string();
        state::save_item(state_file_.parent_path().empty() ? std::filesystem::path(".") : state_file_.parent_path(), name,
                         {state::text_file(name, out.str())});
    } catch (const std::exception& e) {
        // The count and the lock still hold in this process; only a restart would lose them.
        report(PinEvent::Kind::StateError, e.what());
    }
}

void PinLock::expire_if_due(std::int64_t now) {
    if (locked_until_ns_ == 0 || now < locked_until_ns_) return;
    locked_until_ns_ = 0;
    failures_ = 0;
    save();
    report(PinEvent::Kind::LockExpired);
}

bool PinLock::locked() {
    expire_if_due(now_());
    return locked_until_ns_ != 0;
}

double PinLock::remaining_s() {
    const std::int64_t now = now_();
    expire_if_due(now);
    return locked_until_ns_ == 0 ? 0.0 : static_cast<double>(locked_until_ns_ - now) * 1e-9;
}

void PinLock::set_policy(const MaintenanceSection& policy) { policy_ = policy; }

PinResult PinLock::try_pin(const std::string& pin) {
    expire_if_due(now_());
    report(PinEvent::Kind::Attempt);
    if (locked_until_ns_ != 0) {
        report(PinEvent::Kind::Refused, "locked out");
        return PinResult::LockedOut;
    }
    if (policy_.pin_hash.empty()) {
        report(PinEvent::Kind::Refused, "no PIN configured; the key switch opens the menu");
        return PinResult::Disabled;
    }
    if (verify_pin(pin, policy_.pin_hash)) {
        const bool had_failures = failures_ != 0;
        failures_ = 0;
        if (had_failures) save();
        report(PinEvent::Kind::Success);
        return PinResult::Accepted;
    }
    ++failures_;
    const bool lock = failures_ >= policy_.max_attempts;
    if (lock) locked_until_ns_ = now_() + lockout_ns(policy_);
    // Saved before it is reported: a crash in the reporter must not lose the count.
    save();
    report(PinEvent::Kind::Failure);
    if (!lock) return PinResult::Rejected;
    report(PinEvent::Kind::LockedOut, std::to_string(failures_) + " wrong PINs");
    return PinResult::LockedOut;
}

}  // namespace glint::ui
