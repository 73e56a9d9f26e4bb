// Ray queries through a host-built SAH bounding volume hierarchy (rayclass/bvh/bvh.h) traversed
// by cl/bvh.cl: the mainstream acceleration structure, in the same OpenCL kernels and with the
// same intersection routines, that ray classification is compared with (--accel bvh).
#pragma once

#include <memory>

#include "rayclass/bvh/bvh.h"
#include "rayclass/render/ray_query.h"

namespace rayclass::render {

// Builds the hierarchy of `scene` (whose primitives `buffers` holds) and uploads it. The query
// finds hits only; the renderer shades them (QueryResult::shaded = false).
std::unique_ptr<RayQuery> MakeBvhQuery(clrt::Context& ctx, const cl::Program& program,
                                       const SceneBuffers& buffers, const scene::Scene& scene,
                                       const bvh::BuildParams& params = {});

}  // namespace rayclass::render
