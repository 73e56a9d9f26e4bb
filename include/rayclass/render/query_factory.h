// The ray query a render's options name (RenderOptions::accel), built for its scene.
#pragma once

#include <memory>

#include "rayclass/render/options.h"
#include "rayclass/render/ray_query.h"
#include "rayclass/render/stats.h"
#include "rayclass/scene/scene.h"

namespace rayclass::render {

// The query options.accel names, its classification set up with options.classifyParams and
// options.kernel. Its construction time goes into stats.timeS (classify_setup, bvh_build; auto
// builds its BVH later, when it first needs one). The caller keeps every argument alive longer
// than the query.
std::unique_ptr<RayQuery> MakeQuery(clrt::Context& ctx, const cl::Program& program,
                                    const SceneBuffers& buffers, const scene::Scene& scene,
                                    const RenderOptions& options, RenderStats& stats);

}  // namespace rayclass::render
