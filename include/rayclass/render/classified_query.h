// The ray query through the ray classification: the host classifies each batch of rays into the
// lazily built 5D hierarchy (one per generation, so a generation's later batches land in the
// remainders of its earlier ones), sends the leaves' ray ids and candidate
// lists as flat arrays, and one of three kernel styles (cl/classified.cl) answers the rays of
// every leaf. The rays themselves are already on the device.
#pragma once

#include <memory>

#include "rayclass/classify/params.h"
#include "rayclass/render/options.h"
#include "rayclass/render/ray_query.h"

namespace rayclass::render {

std::unique_ptr<RayQuery> MakeClassifiedQuery(clrt::Context& ctx, const cl::Program& program,
                                              const SceneBuffers& buffers,
                                              const scene::Scene& scene,
                                              const classify::Params& params, KernelStyle style);

}  // namespace rayclass::render
