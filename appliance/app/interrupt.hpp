// SIGINT, SIGTERM and SIGHUP for the command-line tools: nothing half-written is left behind.
//
// Signals are taken by one thread with sigwait(), not by a handler, so the clean-up may do real
// work (remove a directory) without async-signal-safety rules. A signal first removes every live
// StagingDirectory; then, if a StopRequest is alive, it only sets that flag (the command winds
// down by itself, e.g. `glint sensors` closing its recording); otherwise the process exits at once
// with 128 + the signal number, the shell's convention (130 for Ctrl-C, 143 for SIGTERM).
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace glint::app {

// Blocks the three signals in the calling thread and starts the thread that waits for them. Call
// first in main(), before any other thread exists, so that every later thread inherits the mask.
void install_interrupt_handling();

// While one lives, a signal sets requested() instead of ending the process.
class StopRequest {
public:
    StopRequest();
    ~StopRequest();
    StopRequest(const StopRequest&) = delete;
    StopRequest& operator=(const StopRequest&) = delete;
    bool requested() const;
};

// While one lives, SIGHUP does not stop anything: it sets a flag that take() reads and clears (the
// kiosk reloads its configuration; docs/service.md).
class ReloadRequest {
public:
    ReloadRequest();
    ~ReloadRequest();
    ReloadRequest(const ReloadRequest&) = delete;
    ReloadRequest& operator=(const ReloadRequest&) = delete;
    bool take();  // a SIGHUP came since the last call
};

// A private directory PARENT/.glint-staging-PID in which a command writes every output file
// before moving them into place together (all or nothing). It is removed by the destructor, and by
// a signal at any moment, except while write() or commit() runs: a signal then waits for them.
class StagingDirectory {
public:
    explicit StagingDirectory(const std::filesystem::path& parent);
    ~StagingDirectory();
    StagingDirectory(const StagingDirectory&) = delete;
    StagingDirectory& operator=(const StagingDirectory&) = delete;

    // Where staged file `name` is written.
    std::filesystem::path file(const std::string& name) const { return dir_ / name; }
    // Runs `write_files`, which writes into file(...), with signals held off.
    void write(const std::function<void()>& write_files);
    // Renames each staged file into the parent directory, in order, and removes the staging
    // directory, with signals held off. Test hook: GLINT_TEST_HOLD_STAGING_MS=N in the environment
    // keeps the staged files N ms before this (so a test can signal the command while they exist).
    void commit(const std::vector<std::string>& names);

private:
    std::filesystem::path parent_, dir_;
};

}  // namespace glint::app
