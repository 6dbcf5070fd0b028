// glint_state_writer: the fault tests' writer (state_versions.hpp) as a program, to run by hand:
// it saves version after version of every state item into STATE_DIR until killed.
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

#include "tests/faults/state_versions.hpp"

int main(int argc, char** argv) {
    if (argc >= 2 && (std::strcmp(argv[1], "--help") == 0 || std::strcmp(argv[1], "-h") == 0)) {
        std::printf(
            "usage: glint_state_writer STATE_DIR [ROUNDS] [REPORT_FD]\n"
            "Saves new versions of the scene (env.exr + env.coverage.exr), the calibration, a settings\n"
            "file and the PIN lock into STATE_DIR through the appliance's state store, one round after\n"
            "another (ROUNDS, 0 = until killed), continuing from the versions found there. Writes a line\n"
            "after each save to REPORT_FD (default 1). tests/faults' power-loss test SIGKILLs it.\n");
        return 0;
    }
    if (argc < 2 || argc > 4) {
        std::fprintf(stderr, "glint_state_writer: usage: glint_state_writer STATE_DIR [ROUNDS] [REPORT_FD] (--help)\n");
        return 2;
    }
    try {
        return glint::faults::run_writer(argv[1], argc >= 4 ? std::stoi(argv[3]) : 1, argc >= 3 ? std::stoll(argv[2]) : 0);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "glint_state_writer: %s\n", e.what());
        return 1;
    }
}
