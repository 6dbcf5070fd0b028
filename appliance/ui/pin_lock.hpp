// The maintenance menu's PIN (docs/service.md, "The maintenance PIN"): hashed with crypt(3)
// (libxcrypt, yescrypt "$y$"), stored in the config as [maintenance] pin_hash; PinLock counts
// wrong PINs and locks the prompt for lockout_s after max_attempts of them. The count and the
// lock are kept in a small state file written atomically, so neither a crash, a restart by
// systemd nor a power cycle opens the lock early. Every attempt, success, failure and lock-out
// is reported through a callback (the kiosk writes them to the journal).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "appliance/ui/config.hpp"

namespace glint::ui {

// A new crypt(3) hash of `pin` with the yescrypt method at libxcrypt's default cost and a
// random salt from the OS. A PIN is 4 to 16 decimal digits (what the menu's keypad enters);
// anything else throws glint::InputError saying why. Throws glint::RuntimeError when libxcrypt
// fails (no random bytes, method disabled).
std::string hash_pin(const std::string& pin);

// Whether `pin` matches `hash` (crypt_r with the hash as setting, then a comparison whose time
// does not depend on where the strings differ). A malformed or empty hash matches nothing.
bool verify_pin(const std::string& pin, const std::string& hash);

// Why `hash` cannot be a pin_hash (not a crypt(3) hash, a legacy method such as DES or MD5, a
// truncated hash), or nullopt when it can. Used by the config's validation.
std::optional<std::string> pin_hash_problem(const std::string& hash);

enum class PinResult {
    Accepted,   // the menu opens
    Rejected,   // a wrong PIN, attempts remain
    LockedOut,  // a wrong PIN that started the lock-out, or any PIN while locked
    Disabled,   // no pin_hash configured: only the key switch opens the menu
};
const char* pin_result_name(PinResult result);

struct PinEvent {
    enum class Kind {
        Attempt,      // a PIN was entered (before it is checked)
        Success,      // it matched; the failure count is reset
        Failure,      // it did not match
        LockedOut,    // the lock-out started (or was restored after a restart or reboot)
        Refused,      // a PIN entered while locked, or with no PIN configured; not checked
        LockExpired,  // the lock-out is over; the failure count is reset
        StateError,   // the state file could not be read or written (the lock still holds in memory)
    };
    Kind kind = Kind::Attempt;
    int failures = 0;          // consecutive wrong PINs so far
    int max_attempts = 0;
    double locked_for_s = 0;   // LockedOut, Refused: what remains of the lock-out
    std::string detail;        // StateError, Refused, LockedOut: why
};
const char* pin_event_name(PinEvent::Kind kind);
// One line for the journal, e.g. "maintenance PIN: failure 3 of 5".
std::string describe(const PinEvent& event);

// CLOCK_MONOTONIC in ns (the default clock of PinLock).
std::int64_t monotonic_now_ns();
// This boot's id (/proc/sys/kernel/random/boot_id), "" when unreadable.
std::string current_boot_id();

// Not thread-safe: one thread (the kiosk's main loop) uses it. try_pin() hashes once with
// yescrypt (about 20 ms on the build machine, more on the appliance's cores): call it from the
// PIN prompt's confirm, not every frame.
class PinLock {
public:
    using Clock = std::function<std::int64_t()>;  // monotonic ns
    using Reporter = std::function<void(const PinEvent&)>;

    // Restores the count and the lock from `state_file` (missing: a fresh start). The lock's
    // end is kept on the monotonic clock with the boot id: after a restart in the same boot the
    // remaining time holds; after a reboot (a new boot id, the clock starts again) a lock-out
    // in progress starts again in full. An unreadable state file locks for lockout_s (fail
    // closed: corrupting the file must not open the lock) and is rewritten.
    PinLock(const MaintenanceSection& policy, std::filesystem::path state_file, Reporter report,
            Clock now = monotonic_now_ns, std::string boot_id = current_boot_id());

    PinResult try_pin(const std::string& pin);

    // A SIGHUP's new pin_hash, max_attempts and lockout_s. The count and a running lock-out
    // are kept (a lock-out ends when it was due under the policy that started it).
    void set_policy(const MaintenanceSection& policy);

    bool locked();              // ends a lock-out that is due (reporting LockExpired)
    double remaining_s();       // of the lock-out, 0 when not locked
    int failures() const { return failures_; }

private:
    void expire_if_due(std::int64_t now);
    void save();
    void load();
    void report(PinEvent::Kind kind, std::string detail = {});

    MaintenanceSection policy_;
    std::filesystem::path state_file_;
    Reporter report_;
    Clock now_;
    std::string boot_id_;
    int failures_ = 0;
    std::int64_t locked_until_ns_ = 0;  // 0 = not locked
};

}  // namespace glint::ui
