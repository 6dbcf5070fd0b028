#include "appliance/capture/camera_factory.hpp"

#include "appliance/capture/libcamera_source.hpp"
#include "appliance/capture/replay_camera.hpp"
#include "appliance/core/errors.hpp"

namespace glint::capture {

CameraBackends capture_camera_backends() {
    CameraBackends b;
    b["libcamera"] = {"libcamera[:ID]", [](const std::string&, const std::string& id, host::Clock&) {
                          LibcameraOptions o;
                          o.camera_id = id;
                          return std::unique_ptr<CameraSource>(std::make_unique<LibcameraSource>(o));
                      }};
    b["replay"] = {"replay:DIR", [](const std::string& spec, const std::string& dir, host::Clock& clock) {
                       if (dir.empty()) throw InputError("camera '" + spec + "': no session directory (replay:DIR)");
                       return std::unique_ptr<CameraSource>(std::make_unique<ReplayCamera>(open_session(dir), clock));
                   }};
    return b;
}

std::unique_ptr<CameraSource> make_camera_source(const std::string& spec, const CameraBackends& backends,
                                                 host::Clock& clock) {
    const std::size_t colon = spec.find(':');
    const std::string kind = spec.substr(0, colon);
    const auto backend = backends.find(kind);
    if (backend == backends.end()) {
        std::string accepted;
        for (const auto& [name, b] : backends) accepted += (accepted.empty() ? "" : ", ") + b.usage;
        throw InputError("camera '" + spec + "': unknown kind '" + kind + "' (accepted: " + accepted + ")");
    }
    return backend->second.make(spec, colon == std::string::npos ? "" : spec.substr(colon + 1), clock);
}

}  // namespace glint::capture
