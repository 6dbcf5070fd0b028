// Subcommands of the `glint` binary. Each registers itself on the CLI11 app and
// returns the function main() runs when that subcommand was chosen.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>

namespace glint::app {

using CommandRunner = std::function<int()>;

struct Command {
    CLI::App* parser;   // the subcommand, to ask whether it was given
    CommandRunner run;  // what to run when it was
};

// `glint convolve IN.exr --out DIR ...`
Command add_convolve_command(CLI::App& app);

// `glint compare MAP.exr REFERENCE.exr`
Command add_compare_command(CLI::App& app);

// `glint simulate --env ENV.exr --trajectory guided|FILE --out SESSION/` (capture_commands.cpp)
Command add_simulate_command(CLI::App& app);

// `glint capture --session SESSION/ --out env.exr ...` (capture_commands.cpp)
Command add_capture_command(CLI::App& app);

// `glint sensors --source SPEC ...` (sensors_command.cpp)
Command add_sensors_command(CLI::App& app);

// `glint calibrate response ...` (capture_commands.cpp)
Command add_calibrate_command(CLI::App& app);

// `glint cameras`: what libcamera finds (capture_commands.cpp)
Command add_cameras_command(CLI::App& app);

}  // namespace glint::app
