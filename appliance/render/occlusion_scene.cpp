#include "appliance/render/occlusion_scene.hpp"

#include <string>

#include "appliance/core/errors.hpp"

namespace glint::render {

OcclusionScene::OcclusionScene(const Mesh& mesh, const char* what) : what_(what) {
    if (mesh.positions.empty() || mesh.indices.size() < 3)
        throw InputError(std::string(what) + ": the mesh " + mesh.source + " has no triangles");
    for (const std::uint32_t i : mesh.indices)
        if (i >= mesh.positions.size())
            throw InputError(std::string(what) + ": the mesh " + mesh.source + " has an index out of range");
    device_ = rtcNewDevice(nullptr);
    if (!device_)
        throw RuntimeError(std::string(what) + ": Embree could not create a device (error " +
                           std::to_string(int(rtcGetDeviceError(nullptr))) + ")");
    scene_ = rtcNewScene(device_);
    RTCGeometry geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                                 3 * sizeof(float), mesh.positions.size()));
    auto* triangles = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                     3 * sizeof(unsigned), mesh.indices.size() / 3));
    if (!vertices || !triangles) {
        rtcReleaseGeometry(geometry);
        check("allocating the buffers");
        rtcReleaseScene(scene_);
        rtcReleaseDevice(device_);
        throw RuntimeError(std::string(what) + ": Embree could not allocate the buffers");
    }
    for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
        vertices[3 * i] = mesh.positions[i].x;
        vertices[3 * i + 1] = mesh.positions[i].y;
        vertices[3 * i + 2] = mesh.positions[i].z;
    }
    for (std::size_t i = 0; i < mesh.indices.size() / 3 * 3; ++i) triangles[i] = mesh.indices[i];
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene_, geometry);
    rtcReleaseGeometry(geometry);
    rtcCommitScene(scene_);
    check("building the scene");
}

OcclusionScene::~OcclusionScene() {
    if (scene_) rtcReleaseScene(scene_);
    if (device_) rtcReleaseDevice(device_);
}

RTCRay OcclusionScene::ray(const glm::dvec3& origin, const glm::dvec3& direction, float tnear, float tfar, unsigned id) {
    RTCRay r;
    r.org_x = float(origin.x);
    r.org_y = float(origin.y);
    r.org_z = float(origin.z);
    r.tnear = tnear;
    r.dir_x = float(direction.x);
    r.dir_y = float(direction.y);
    r.dir_z = float(direction.z);
    r.time = 0.0f;
    r.tfar = tfar;
    r.mask = 0xFFFFFFFFu;
    r.id = id;
    r.flags = 0;
    return r;
}

void OcclusionScene::trace(std::vector<RTCRay>& rays) const {
    if (rays.empty()) return;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    rtcOccluded1M(scene_, &context, rays.data(), unsigned(rays.size()), sizeof(RTCRay));
}

void OcclusionScene::check(const char* stage) const {
    const RTCError e = rtcGetDeviceError(device_);
    if (e != RTC_ERROR_NONE)
        throw RuntimeError(std::string(what_) + ": Embree failed " + stage + " (error " + std::to_string(int(e)) + ")");
}

}  // namespace glint::render
