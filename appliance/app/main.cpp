// glint: the appliance's command-line tools. This executable holds the commands that need only
// core, convolution, GL and the sensor bridge, so it starts in milliseconds; the commands that
// need OpenCV or libcamera run in glint-vision (commands.hpp), started from here.
#include <cstdio>
#include <cstring>
#include <exception>

#include "appliance/app/command_line.hpp"
#include "appliance/core/memory.hpp"

int main(int argc, char** argv) {
    // The convolution's buffers fault in 2 MiB pages (memory.hpp); other commands start faster
    // without the re-exec.
    if (argc > 1 && std::strcmp(argv[1], "convolve") == 0) glint::reexec_with_huge_pages(argv);
    try {
        glint::app::exec_vision_command_if_named(argc, argv);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "glint: failed: %s\n", e.what());
        return 1;
    }
    glint::keep_freed_memory();
    constexpr glint::app::CommandRegistrar commands[] = {
        glint::app::add_convolve_command, glint::app::add_compare_command, glint::app::add_sensors_command,
        glint::app::add_render_command, glint::app::add_bake_ao_command};
    return glint::app::run_command_line(argc, argv, commands, /*list_vision_commands=*/true);
}
