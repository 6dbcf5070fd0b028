// A mesh as an Embree 3 scene for occlusion rays (docs/render.md): the one place that sets Embree
// up, shared by the ambient-occlusion bake (ao_bake.cpp) and the table-shadow bake
// (shadow_bake.cpp).
#pragma once

#include <embree3/rtcore.h>

#include <vector>

#include <glm/glm.hpp>

#include "appliance/render/mesh.hpp"

namespace glint::render {

class OcclusionScene {
public:
    // Builds the scene of the mesh's triangles. `what` names the caller in messages ("ao bake").
    // Throws InputError for an empty mesh or an index out of range, RuntimeError when Embree fails.
    OcclusionScene(const Mesh& mesh, const char* what);
    ~OcclusionScene();
    OcclusionScene(const OcclusionScene&) = delete;
    OcclusionScene& operator=(const OcclusionScene&) = delete;

    // One occlusion ray in Embree's layout, from `origin` along `direction` over (tnear, tfar).
    static RTCRay ray(const glm::dvec3& origin, const glm::dvec3& direction, float tnear, float tfar, unsigned id = 0);
    // Traces the rays as one stream (Embree packs rays that share an origin: about twice as fast
    // as one rtcOccluded1 each) and marks the occluded ones: their tfar becomes -infinity.
    // Thread-safe: call it from any number of threads.
    void trace(std::vector<RTCRay>& rays) const;
    static bool occluded(const RTCRay& r) { return !(r.tfar >= 0.0f); }
    // Throws RuntimeError naming `stage` when Embree reported an error.
    void check(const char* stage) const;

private:
    RTCDevice device_ = nullptr;
    RTCScene scene_ = nullptr;
    const char* what_;
};

}  // namespace glint::render
