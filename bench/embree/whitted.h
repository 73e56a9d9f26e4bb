// A Whitted ray tracer on Embree 3: the whole-frame peer of rayclass (scripts/yardstick). It
// renders the model of cl/shade.cl (and of the double-precision reference renderer) in float on
// the host: emission + ambient, one shadow ray per point light, mirror and refraction rays with
// the same weights, Fresnel split, depth and weight limits, and the same ray offsets
// (geometry/offset.h). Embree answers every query: the image is cut into 8x8-pixel tiles that
// threads take in turn, and each tile is traced generation by generation in packets of 16
// (rtcIntersect16 / rtcOccluded16; eye rays in 4x4 blocks and in coherent mode), the way
// Embree's packet API is meant to be used by a renderer.
#pragma once

#include <cstdint>

#include "embree_scene.h"
#include "rayclass/image/image.h"
#include "rayclass/scene/scene.h"

namespace rayclass::bench {

struct WhittedOptions {
    uint32_t maxDepth = 6;    // deepest secondary ray (eye rays are depth 0), as --max-depth
    float minWeight = 1e-3f;  // as --min-weight
    int threads = 0;          // 0: one per core
    bool ids = false;         // fill the image's id layer with the eye rays' first hits
};

struct WhittedStats {
    double buildSeconds = 0, traceSeconds = 0;
    uint64_t eye = 0, shadow = 0, reflection = 0, refraction = 0;
};

// Renders `scene` through its camera at the camera's size.
image::Image RenderWhitted(const scene::Scene& scene, const WhittedOptions& options,
                           WhittedStats& stats);

}  // namespace rayclass::bench
