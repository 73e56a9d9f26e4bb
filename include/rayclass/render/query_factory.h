// The ray query a render's options name (RenderOptions::accel), built for its scene.
#pragma once

#include <memory>

#include "rayclass/render/bvh_query.h"
#include "rayclass/render/options.h"
#include "rayclass/render/ray_query.h"
#include "rayclass/render/stats.h"
#include "rayclass/scene/scene.h"

namespace rayclass::render {

// The BVH build of `scene` started now, where options.accel may use the tree: bvh, or auto on a
// render that may spawn secondary rays (auto builds its BVH only for them); null elsewhere.
std::shared_ptr<BvhBuild> StartBvhBuild(const scene::Scene& scene, const RenderOptions& options);

// The query options.accel names, its classification set up with options.classifyParams and
// options.kernel, its BVH taken from `bvhBuild` (built here when null). Its construction time
// goes into stats.timeS (classify_setup; bvh_build, the time this thread waited for the tree
// and uploaded it, and bvh_build_thread, the build's own; auto takes its BVH later, when it
// first needs one). The caller keeps every argument alive longer than the query.
std::unique_ptr<RayQuery> MakeQuery(clrt::Context& ctx, const cl::Program& program,
                                    const SceneBuffers& buffers, const scene::Scene& scene,
                                    const RenderOptions& options, RenderStats& stats,
                                    std::shared_ptr<BvhBuild> bvhBuild = nullptr);

}  // namespace rayclass::render
