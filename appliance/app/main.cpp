// glint: the appliance's command-line tools. This executable holds the commands that need only
// core, convolution, GL and the sensor bridge, so it starts in milliseconds; the commands that
// need OpenCV or libcamera run in glint-vision (commands.hpp), started from here.
#include <cstdio>
#include <exception>

#include "appliance/app/command_line.hpp"
#include "appliance/core/memory.hpp"

int main(int argc, char** argv) {
    try {
        glint::app::exec_vision_command_if_named(argc, argv);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "glint: failed: %s\n", e.what());
        return 1;
    }
    glint::keep_freed_memory();
    constexpr glint::app::CommandRegistrar commands[] = {
        glint::app::add_convolve_command, glint::app::add_compare_command, glint::app::add_sensors_command};
    return glint::app::run_command_line(argc, argv, commands, /*list_vision_commands=*/true);
}
