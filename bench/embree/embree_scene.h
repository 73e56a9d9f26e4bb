// A rayclass scene as an Embree 3 scene, for the peer measurements of bench/: triangles as
// Embree triangles, spheres and quadrics as user geometry that runs rayclass's own float
// intersection routines (geometry/intersect.h), so Embree answers the same analytic surfaces.
// The BVH is built with HIGH quality, Embree's best for tracing many rays.
#pragma once

#include <embree3/rtcore.h>

#include <cstdint>
#include <memory>

#include "rayclass/scene/scene.h"

namespace rayclass::bench {

class EmbreeScene {
  public:
    // Builds the BVH on `threads` threads. Throws rayclass::Error when Embree fails or the scene
    // has Bezier patches, which the peer does not trace.
    EmbreeScene(const scene::Scene& scene, int threads);

    RTCScene handle() const { return scene_.get(); }
    double buildSeconds() const { return buildSeconds_; }
    // rayclass's global primitive id of an Embree hit (triangles, then spheres, then quadrics).
    uint32_t GlobalId(unsigned geomID, unsigned primID) const {
        return geomID == kTriangles ? primID
               : geomID == kSpheres ? sphereBase_ + primID
                                    : quadricBase_ + primID;
    }

    static constexpr unsigned kTriangles = 0, kSpheres = 1, kQuadrics = 2;

  private:
    std::unique_ptr<RTCDeviceTy, decltype(&rtcReleaseDevice)> device_{nullptr, rtcReleaseDevice};
    std::unique_ptr<RTCSceneTy, decltype(&rtcReleaseScene)> scene_{nullptr, rtcReleaseScene};
    uint32_t sphereBase_ = 0, quadricBase_ = 0;
    double buildSeconds_ = 0;
};

}  // namespace rayclass::bench
