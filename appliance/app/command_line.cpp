// The shared front of glint and glint-vision (command_line.hpp).
#include "appliance/app/command_line.hpp"
#include "appliance/core/memory.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "appliance/app/build_info.hpp"
#include "appliance/app/interrupt.hpp"
#include "appliance/core/errors.hpp"

namespace glint::app {
namespace {

constexpr CommandSummary kSummaries[] = {
    {"convolve", "Environment map -> irradiance and Phong reflection maps (EXR) and report.json", false},
    {"compare",
     "Error of a map against a reference map (weighted relative RMS, worst texel, mean/max absolute percentage), "
     "the map read at the reference's texel centres as a renderer reads it (bilinear, or through its lobe where "
     "report.json says so)",
     false},
    {"sensors",
     "Read or replay an orientation source: one line per sample on stdout (appliance monotonic time), the health "
     "figures on stderr once a second",
     false},
    {"render",
     "Render an object lit by an environment map's irradiance and Phong reflection maps on a display (headless by "
     "default): PNG frame, AOVs (radiance, normal, reflection EXR), frame-time statistics",
     false},
    {"bake-ao",
     "Bake a model's per-vertex ambient occlusion with Embree into MODEL.ao, which glint render uses", false},
    {"simulate",
     "Render a recorded capture session with ground truth from an equirect HDR map: camera frames through a camera "
     "model (distortion, vignetting, response, noise, auto-exposure) along a trajectory, and the sensor board's "
     "recorded stream from its firmware simulator",
     true},
    {"capture",
     "Run the capture pipeline offline on a recorded or simulated session: HDR accumulation on the sphere -> "
     "environment map (EXR) and its coverage map (<out stem>.coverage.exr)",
     true},
    {"calibrate", "Camera calibrations from recorded frames, stored in a calibration file", true},
    {"cameras", "List the cameras libcamera finds (exit 1 when there is none)", true},
    {"track",
     "The marker board's pose in every PNG of a directory (CSV, camera_from_board), filtered and bridged through "
     "dropouts by the orientation sensor with --sequence; --print-board draws the board",
     true},
    {"run",
     "The appliance: the kiosk on the live camera, orientation sensor, GPIO button and display of the configuration, "
     "under systemd (READY, STATUS, WATCHDOG; SIGHUP reloads, SIGTERM stops)",
     true},
    {"replay",
     "The kiosk program on a recorded session (camera frames, sensor stream, button events): the visitor flow, "
     "capture, maps and AR view on a display (headless by default); PNG frames and summary.json",
     true},
};

// The first argument that is not an option: the command's name (glint has no global option
// that takes a value).
const char* command_name(int argc, char** argv) {
    for (int i = 1; i < argc; ++i)
        if (argv[i][0] != '-') return argv[i];
    return nullptr;
}

}  // namespace

std::span<const CommandSummary> command_summaries() { return kSummaries; }

const CommandSummary& command_summary(std::string_view name) {
    for (const CommandSummary& s : kSummaries)
        if (s.name == name) return s;
    throw std::logic_error("no command summary for '" + std::string(name) + "'");
}

const char* version_line() {
    static const std::string line = std::string("glint ") + kProjectVersion + " (" + kGitDescribe + ")";
    return line.c_str();
}

void exec_vision_command_if_named(int argc, char** argv) {
    const char* name = command_name(argc, argv);
    if (name == nullptr) return;
    bool vision = false;
    for (const CommandSummary& s : kSummaries) vision = vision || (s.in_vision && s.name == name);
    if (!vision) return;
    std::error_code ec;
    const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
    if (ec) throw RuntimeError(std::string("cannot find this executable (/proc/self/exe): ") + ec.message());
    const std::string vision_path = (self.parent_path() / "glint-vision").string();
    std::vector<char*> args(argv, argv + argc);
    args.push_back(nullptr);
    // The kiosk's allocator chosen here, so that glint-vision starts once, already on it.
    if (std::strcmp(name, "run") == 0 || std::strcmp(name, "replay") == 0) preload_kiosk_allocator_for_exec();
    ::execv(vision_path.c_str(), args.data());
    throw RuntimeError("'" + std::string(name) + "' runs in " + vision_path + ", which cannot be started: " +
                       std::strerror(errno));
}

int run_command_line(int argc, char** argv, std::span<const CommandRegistrar> commands, bool list_vision_commands) {
    install_interrupt_handling();
    CLI::App app{"Glint: lights virtual objects with the captured light of the room.", "glint"};
    app.require_subcommand(1);
    app.set_version_flag("--version", version_line(), "Print the version and the build's git description");
    std::vector<Command> registered;
    for (const CommandRegistrar add : commands) registered.push_back(add(app));
    if (list_vision_commands)
        for (const CommandSummary& s : kSummaries)
            if (s.in_vision) app.add_subcommand(std::string(s.name), std::string(s.summary))->allow_extras();

    try {
        app.parse(argc, argv);
    } catch (const CLI::CallForHelp&) {
        std::printf("%s", app.help().c_str());
        return 0;
    } catch (const CLI::CallForAllHelp&) {
        std::printf("%s", app.help("", CLI::AppFormatMode::All).c_str());
        return 0;
    } catch (const CLI::CallForVersion&) {
        std::printf("%s\n", version_line());
        return 0;
    } catch (const CLI::ParseError& e) {
        std::fprintf(stderr, "glint: error: %s (see glint --help)\n", e.what());
        return 2;
    }

    try {
        for (const auto& command : registered)
            if (command.parser->parsed()) return command.run();
        // Only a listed glint-vision command is left (normally exec'd before parsing).
        exec_vision_command_if_named(argc, argv);
        std::fprintf(stderr, "glint: error: no command given (see glint --help)\n");
        return 2;
    } catch (const InputError& e) {
        std::fprintf(stderr, "glint: error: %s\n", e.what());
        return 2;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "glint: failed: %s\n", e.what());
        return 1;
    }
}

}  // namespace glint::app
