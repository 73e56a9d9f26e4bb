// The device buffers the kernels share: the scene's, uploaded once, and a batch's rays and
// shading outputs (layouts: cl/shared/rc_types.h).
#pragma once

#include <cstddef>
#include <cstdint>

#include "rayclass/clrt/context.h"
#include "rayclass/scene/scene.h"
#include "rc_types.h"

namespace rayclass::render {

// Scene data every kernel reads, uploaded once.
struct SceneBuffers {
    cl::Buffer triangles, triangleShading, spheres, quadrics, materials, lights, params;
    RcRenderParams hostParams{};

    SceneBuffers(clrt::Context& ctx, const scene::Scene& scene, const RcRenderParams& renderParams);

    // Bytes of the geometry on the device: triangles and their shading data, spheres, and the
    // analytic buffer (quadrics, patch boxes and their control points).
    uint64_t GeometryBytes() const;
};

// A device array of rays as its two parallel arrays (rc_types.h): RcRay, all a query reads, and
// RcRayInfo, which only ray generation and shading touch.
struct RayBuffers {
    cl::Buffer rays, info;
};

// Shadow slots as their two parallel arrays (rc_types.h): RcRay toward the light, all the
// occlusion query reads, and the light's contribution (rc_float4, w = 1 when the slot is live).
struct ShadowBuffers {
    cl::Buffer rays, contribution;
};

// What shading reads and writes per batch (see cl/shade.cl): it reads the batch's RcRayInfo and
// writes radiance and normal per ray, nLights shadow slots per ray, two secondary slots per ray
// and their spawned flags.
struct ShadeBuffers {
    cl::Buffer rayInfo;  // the batch's, set for each batch (null for eye rays: rc_types.h)
    cl::Buffer radiance, normals;
    // Whether the batch's shading normals are wanted (the renderer: for the normal AOV). Without
    // them a kernel gets no normals buffer and writes none, sparing a buffer's worth of memory
    // traffic.
    bool writeNormals = true;

    // The normals buffer a shading kernel gets: none unless the normals are wanted.
    cl::Buffer NormalsOut() const { return writeNormals ? normals : cl::Buffer(); }
    ShadowBuffers shadow;
    RayBuffers secondary;
    cl::Buffer spawned;
};

// The secondary slots of a batch of n rays (RC_SECONDARY_SLOT): two a ray, in whole runs.
constexpr size_t SecondarySlots(size_t n) {
    return (n + RC_SECONDARY_RUN - 1) / RC_SECONDARY_RUN * (2 * RC_SECONDARY_RUN);
}

// ShadeBuffers for batches of up to `rays` rays and `nLights` lights (rayInfo left unset: it is
// the batch's own).
ShadeBuffers MakeShadeBuffers(clrt::Context& ctx, size_t rays, uint32_t nLights);

}  // namespace rayclass::render
