// Subcommands of `glint`. Each registers itself on a CLI11 app and returns the function that runs
// when it was chosen. They are split over two executables so that a command loads only the
// libraries it needs (docs/architecture.md, "Two executables"):
//   glint         convolve, compare, sensors, render, bake-ao: core, convolution, GL and displays, render,
//                 sensor bridge;
//   glint-vision  simulate, capture, calibrate, cameras, track, replay, run: everything that needs OpenCV or libcamera,
//                 whose loading alone takes longer than a whole small convolution.
// `glint` runs glint-vision (execv, same arguments) for the commands that live there.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <span>
#include <string_view>

namespace glint::app {

using CommandRunner = std::function<int()>;

struct Command {
    CLI::App* parser;   // the subcommand, to ask whether it was given
    CommandRunner run;  // what to run when it was
};

using CommandRegistrar = Command (*)(CLI::App&);

// Name and one-line summary of every command, for the registration and for `glint --help`
// (which lists glint-vision's commands without loading it).
struct CommandSummary {
    std::string_view name;
    std::string_view summary;
    bool in_vision;  // lives in glint-vision
};
std::span<const CommandSummary> command_summaries();
// The summary of `name`; throws std::logic_error for a name that is not in the table.
const CommandSummary& command_summary(std::string_view name);

// glint (one file each)
Command add_convolve_command(CLI::App& app);  // glint convolve IN.exr --out DIR ...
Command add_compare_command(CLI::App& app);   // glint compare MAP.exr REFERENCE.exr
Command add_sensors_command(CLI::App& app);   // glint sensors --source SPEC ...
Command add_render_command(CLI::App& app);    // glint render --env ENV.exr --model sphere ...
Command add_bake_ao_command(CLI::App& app);   // glint bake-ao MODEL [--rays N] [--out FILE]

// glint-vision (one file each)
Command add_simulate_command(CLI::App& app);   // glint simulate --env ENV.exr --out SESSION ...
Command add_capture_command(CLI::App& app);    // glint capture --session SESSION --out env.exr ...
Command add_calibrate_command(CLI::App& app);  // glint calibrate response|vignetting|alignment|intrinsics
Command add_cameras_command(CLI::App& app);    // glint cameras
Command add_track_command(CLI::App& app);      // glint track --frames DIR --out poses.csv ...
Command add_replay_command(CLI::App& app);
Command add_run_command(CLI::App& app);        // glint run [--config FILE]     // glint replay SESSION --out DIR [--realtime] ...

}  // namespace glint::app
