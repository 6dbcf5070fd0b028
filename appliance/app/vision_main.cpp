// glint-vision: the glint commands that need OpenCV or libcamera (commands.hpp). Users run them
// as `glint simulate ...`; glint execs this program with the same arguments.
#include "appliance/app/command_line.hpp"
#include "appliance/core/memory.hpp"

int main(int argc, char** argv) {
    glint::keep_freed_memory();
    constexpr glint::app::CommandRegistrar commands[] = {
        glint::app::add_simulate_command, glint::app::add_capture_command, glint::app::add_calibrate_command,
        glint::app::add_cameras_command, glint::app::add_track_command,
        glint::app::add_replay_command, glint::app::add_run_command};
    return glint::app::run_command_line(argc, argv, commands, /*list_vision_commands=*/false);
}
