// glint-vision: the glint commands that need OpenCV or libcamera (commands.hpp). Users run them
// as `glint simulate ...`; glint execs this program with the same arguments.
#include "appliance/app/command_line.hpp"
#include "appliance/core/memory.hpp"

#include <cstring>

int main(int argc, char** argv) {
    // The kiosk runs for weeks on jemalloc and gives back what each visit freed; the one-shot
    // commands keep freed buffers for speed (memory.hpp).
    const bool kiosk = argc > 1 && (std::strcmp(argv[1], "run") == 0 || std::strcmp(argv[1], "replay") == 0);
    if (kiosk) {
        glint::reexec_with_kiosk_allocator(argv);  // returns when jemalloc is in place or not to be had
        glint::bound_freed_memory();               // glibc's policy; nothing under jemalloc
    }
    else glint::keep_freed_memory();
    constexpr glint::app::CommandRegistrar commands[] = {
        glint::app::add_simulate_command, glint::app::add_capture_command, glint::app::add_calibrate_command,
        glint::app::add_cameras_command, glint::app::add_track_command,
        glint::app::add_replay_command, glint::app::add_run_command};
    return glint::app::run_command_line(argc, argv, commands, /*list_vision_commands=*/false);
}
