// The ray query through the ray classification: the host classifies each batch of rays into the
// lazily built 5D hierarchy (one per generation, so a generation's later batches land in the
// remainders of its earlier ones), sends the leaves' ray ids and candidate
// lists as flat arrays, and one of three kernel styles (cl/classified.cl) answers the rays of
// every leaf. The rays themselves are already on the device.
#pragma once

#include <memory>
#include <string>

#include "rayclass/classify/params.h"
#include "rayclass/render/ray_query.h"

namespace rayclass::render {

enum class KernelStyle {
    kScalar,    // one work-item per ray, one candidate at a time
    kVertex,    // one work-item per ray, 16 candidates per step (float16 lanes over candidates)
    kFragment,  // one work-item per 16 rays of a leaf, lockstep over candidates
    kAuto,      // per leaf: fragment for coherent leaves, vertex otherwise (shadow rays: fragment)
};

KernelStyle ParseKernelStyle(const std::string& name);  // throws UsageError
const char* KernelStyleName(KernelStyle style);

std::unique_ptr<RayQuery> MakeClassifiedQuery(clrt::Context& ctx, const cl::Program& program,
                                              const SceneBuffers& buffers,
                                              const scene::Scene& scene,
                                              const classify::Params& params, KernelStyle style);

}  // namespace rayclass::render
