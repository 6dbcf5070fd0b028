// Camera sources by spec, "KIND[:ARGUMENT]", as the command line and the appliance's config name
// them (docs/capture.md "Camera sources"):
//   libcamera[:ID]   the real camera (the first one libcamera lists, or the one with that id)
//   replay:DIR       a recorded session's frames (replay_camera.hpp)
//   simulator:...    frames rendered from an HDR map (appliance/sim adds this kind itself)
// Capture has the first two; a module that depends on capture (the simulator) adds its own kind
// to the table, so capture depends on none of them. Whoever picks the camera (the app) fills
// the table.
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>

#include "appliance/capture/camera_source.hpp"

namespace glint::capture {

struct CameraBackend {
    std::string usage;  // the accepted form, e.g. "replay:DIR", for error messages
    // Makes the source (not started) from what follows "KIND:" ("" when nothing does). `clock`
    // paces sources that deliver frames at due times (replay, simulator). Throws InputError
    // naming the spec when the argument is unusable.
    std::function<std::unique_ptr<CameraSource>(const std::string& spec, const std::string& argument,
                                                host::Clock& clock)>
        make;
};

// Backends by kind.
using CameraBackends = std::map<std::string, CameraBackend>;

// Capture's own backends: libcamera and replay.
CameraBackends capture_camera_backends();

// The source `spec` names. Throws InputError naming the spec and listing every accepted form
// when no backend has its kind.
std::unique_ptr<CameraSource> make_camera_source(const std::string& spec, const CameraBackends& backends,
                                                 host::Clock& clock);

}  // namespace glint::capture
