// glint: the appliance's single binary. Parses the command line, runs one
// subcommand, and turns errors into one line on stderr and a truthful exit
// code: 0 success, 2 bad input, 1 any other failure (DESIGN.md, Commands).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <vector>

#include "appliance/app/commands.hpp"
#include "appliance/core/memory.hpp"
#include "appliance/core/errors.hpp"

int main(int argc, char** argv) {
    glint::keep_freed_memory();
    CLI::App app{"Glint: lights virtual objects with the captured light of the room."};
    app.require_subcommand(1);
    const std::vector<glint::app::Command> commands{
        glint::app::add_convolve_command(app), glint::app::add_compare_command(app),
        glint::app::add_simulate_command(app), glint::app::add_capture_command(app),
        glint::app::add_cameras_command(app), glint::app::add_sensors_command(app),
        glint::app::add_calibrate_command(app)};

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp&) {
        std::printf("%s", app.help().c_str());
        return 0;
    } catch (const CLI::CallForAllHelp&) {
        std::printf("%s", app.help("", CLI::AppFormatMode::All).c_str());
        return 0;
    } catch (const CLI::ParseError& e) {
        std::fprintf(stderr, "glint: error: %s (see glint --help)\n", e.what());
        return 2;
    }

    try {
        for (const auto& command : commands)
            if (command.parser->parsed()) return command.run();
        std::fprintf(stderr, "glint: error: no command given (see glint --help)\n");
        return 2;
    } catch (const glint::InputError& e) {
        std::fprintf(stderr, "glint: error: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "glint: failed: %s\n", e.what());
        return 1;
    }
}
