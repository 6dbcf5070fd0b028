// `glint cameras`: the cameras libcamera finds, one per line.
#include <cstdio>
#include <memory>

#include "appliance/app/commands.hpp"
#include "appliance/capture/libcamera_source.hpp"
#include "appliance/core/errors.hpp"

namespace glint::app {

Command add_cameras_command(CLI::App& app) {
    CLI::App* cmd = app.add_subcommand("cameras", std::string(command_summary("cameras").summary));
    return {cmd, [] {
                const std::vector<std::string> cameras = capture::list_libcamera_cameras();
                if (cameras.empty()) throw RuntimeError("libcamera found no camera");
                for (const std::string& c : cameras) std::printf("%s\n", c.c_str());
                return 0;
            }};
}

}  // namespace glint::app
