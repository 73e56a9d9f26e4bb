// The ray query through the ray classification: the host classifies each batch of rays into the
// lazily built 5D hierarchy (one per generation, so a generation's later batches land in the
// remainders of its earlier ones), sends the leaves' ray ids and candidate
// lists as flat arrays, and one of three kernel styles (cl/classified*.cl) answers the rays of
// every leaf. The rays themselves are already on the device.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "rayclass/classify/params.h"
#include "rayclass/render/options.h"
#include "rayclass/render/ray_query.h"

namespace rayclass::render {

std::unique_ptr<RayQuery> MakeClassifiedQuery(clrt::Context& ctx, const cl::Program& program,
                                              const SceneBuffers& buffers,
                                              const scene::Scene& scene,
                                              const classify::Params& params, KernelStyle style);

// The kernel style of the classified query of a render with `options`: options.kernel, but the
// scalar style for the watertight test (the 16-lane kernels are Moeller-Trumbore only).
KernelStyle ClassifiedStyle(const RenderOptions& options);

// The kernel files (cl/classified*.cl) a classified query with `style` on ctx's device may launch
// kernels of: the vertex style's only where auto may choose it (of `params` only vertexGatherCost
// counts, so a render's settings applied to default Params serve).
std::vector<std::string> ClassifiedKernelFiles(const clrt::Context& ctx,
                                               const classify::Params& params, KernelStyle style);

}  // namespace rayclass::render
