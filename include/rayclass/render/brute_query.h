// The ray query without an acceleration: every ray against every primitive (--accel brute), the
// ground truth the other queries must match hit for hit.
#pragma once

#include <memory>

#include "rayclass/render/ray_query.h"

namespace rayclass::render {

std::unique_ptr<RayQuery> MakeBruteForceQuery(clrt::Context& ctx, const cl::Program& program,
                                              const SceneBuffers& scene);

}  // namespace rayclass::render
