// The shared front of both executables (commands.hpp): CLI11 set-up, --version, and the one rule
// for errors: one line on stderr and a truthful exit code, 0 success, 2 bad input (InputError, a
// flag CLI11 rejects), 1 any other failure.
#pragma once

#include <span>

#include "appliance/app/commands.hpp"

namespace glint::app {

// "glint 0.1.0 (v0.1.0-42-gabc1234)": the project version and `git describe` of the build.
const char* version_line();

// Registers `commands` on a CLI11 app named "glint", plus, for `glint --help`, every
// glint-vision command when `list_vision_commands` (running one execs glint-vision), then parses
// argv, runs the chosen command and maps its outcome to an exit code.
int run_command_line(int argc, char** argv, std::span<const CommandRegistrar> commands, bool list_vision_commands);

// When argv names a glint-vision command, replaces this process with glint-vision (from the
// directory of this executable) on the same arguments; returns only when argv names none.
// Throws RuntimeError when glint-vision cannot be started.
void exec_vision_command_if_named(int argc, char** argv);

}  // namespace glint::app
