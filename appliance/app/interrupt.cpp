// Signals for the command-line tools (interrupt.hpp).
#include "appliance/app/interrupt.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <thread>

#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/gl/vt_lock.hpp"

namespace glint::app {
namespace fs = std::filesystem;
namespace {

// What the signal thread acts on. Process-wide by nature: signals are delivered to the process.
struct InterruptState {
    std::mutex mutex;                     // held by the signal thread's clean-up and by staged writes
    std::vector<const fs::path*> staging;  // live staging directories
    int stop_requests = 0;                // live StopRequest objects
    std::atomic<bool> stop_requested{false};
    int reload_requests = 0;              // live ReloadRequest objects: SIGHUP means reload
    std::atomic<bool> reload_requested{false};
};

InterruptState& state() {
    static InterruptState s;
    return s;
}

sigset_t handled_signals() {
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    sigaddset(&set, SIGHUP);
    return set;
}

void on_signal(int signal_number) {
    InterruptState& s = state();
    const std::lock_guard lock(s.mutex);
    if (signal_number == SIGHUP && s.reload_requests > 0) {
        s.reload_requested = true;
        return;
    }
    for (const fs::path* dir : s.staging) {
        std::error_code ec;
        fs::remove_all(*dir, ec);
        std::fprintf(stderr, "glint: %s: removed %s%s\n", strsignal(signal_number), dir->c_str(),
                     ec ? (" (incompletely: " + ec.message() + ")").c_str() : "");
    }
    s.staging.clear();
    if (s.stop_requests > 0) {
        s.stop_requested = true;
        return;
    }
    std::fprintf(stderr, "glint: stopped by %s\n", strsignal(signal_number));
    // _Exit runs no destructor: a KMS display's VT would stay in graphics mode with its keyboard
    // off (gl/vt_lock.hpp). The picture needs nothing: the kernel's fbdev emulation takes the CRTC
    // back when the card's last descriptor closes.
    gl::VtLock::restore_now();
    std::_Exit(128 + signal_number);
}

}  // namespace

void install_interrupt_handling() {
    const sigset_t set = handled_signals();
    if (pthread_sigmask(SIG_BLOCK, &set, nullptr) != 0) throw RuntimeError("cannot block SIGINT/SIGTERM/SIGHUP");
    std::thread([set] {
        for (;;) {
            int signal_number = 0;
            if (sigwait(&set, &signal_number) == 0) on_signal(signal_number);
        }
    }).detach();
}

StopRequest::StopRequest() {
    const std::lock_guard lock(state().mutex);
    ++state().stop_requests;
}

StopRequest::~StopRequest() {
    const std::lock_guard lock(state().mutex);
    --state().stop_requests;
}

bool StopRequest::requested() const { return state().stop_requested; }

ReloadRequest::ReloadRequest() {
    const std::lock_guard lock(state().mutex);
    ++state().reload_requests;
}

ReloadRequest::~ReloadRequest() {
    const std::lock_guard lock(state().mutex);
    --state().reload_requests;
}

bool ReloadRequest::take() { return state().reload_requested.exchange(false); }

StagingDirectory::StagingDirectory(const fs::path& parent)
    : parent_(parent), dir_(parent / (".glint-staging-" + std::to_string(::getpid()))) {
    const std::lock_guard lock(state().mutex);
    std::error_code ec;
    fs::remove_all(dir_, ec);  // a leftover of a killed process that had this pid
    if (!fs::create_directory(dir_, ec)) throw RuntimeError("cannot create " + dir_.string() + ": " + ec.message());
    state().staging.push_back(&dir_);
}

StagingDirectory::~StagingDirectory() {
    const std::lock_guard lock(state().mutex);
    auto& list = state().staging;
    list.erase(std::remove(list.begin(), list.end(), &dir_), list.end());
    std::error_code ec;
    fs::remove_all(dir_, ec);
}

void StagingDirectory::write(const std::function<void()>& write_files) {
    const std::lock_guard lock(state().mutex);
    write_files();
}

void StagingDirectory::commit(const std::vector<std::string>& names) {
    if (const char* hold = std::getenv("GLINT_TEST_HOLD_STAGING_MS"))
        std::this_thread::sleep_for(std::chrono::milliseconds(std::atoi(hold)));
    const std::lock_guard lock(state().mutex);
    for (const std::string& name : names) fs::rename(dir_ / name, parent_ / name);
    fs::remove(dir_);
    sync_directory(parent_);  // the renames survive a power cut
}

}  // namespace glint::app
