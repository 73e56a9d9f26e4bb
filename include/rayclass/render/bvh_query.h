// Ray queries through a host-built SAH bounding volume hierarchy (rayclass/bvh/bvh.h) traversed
// by cl/bvh.cl: the mainstream acceleration structure, in the same OpenCL kernels and with the
// same intersection routines, that ray classification is compared with (--accel bvh).
#pragma once

#include <future>
#include <memory>

#include "rayclass/bvh/bvh.h"
#include "rayclass/bvh/leaf_blocks.h"
#include "rayclass/render/ray_query.h"

namespace rayclass::render {

// Builds the hierarchy of `scene` (whose primitives `buffers` holds) and uploads it. The query
// finds hits only; the renderer shades them (QueryResult::shaded = false). Its Stats().accel:
// bvh_bytes.
std::unique_ptr<RayQuery> MakeBvhQuery(clrt::Context& ctx, const cl::Program& program,
                                       const SceneBuffers& buffers, const scene::Scene& scene,
                                       const bvh::BuildParams& params = {});

// The hierarchy of a scene, built on a worker thread from construction on, so that the host's
// serial setup and first generation overlap it. The scene must stay unchanged until the build
// is taken or this is destroyed; the destructor waits for the build.
class BvhBuild {
  public:
    explicit BvhBuild(const scene::Scene& scene, const bvh::BuildParams& params = {});

    struct Result {
        bvh::BlockedBvh tree;
        double seconds = 0;  // the worker's time on the build
    };
    // Waits for the build and hands its result over; rethrows what the build threw. Once only.
    Result Take() { return result_.get(); }

  private:
    std::future<Result> result_;
};

// The query over `tree`, built over the primitives `buffers` holds (kept by the query, whose
// kernels may read it in place).
std::unique_ptr<RayQuery> MakeBvhQuery(clrt::Context& ctx, const cl::Program& program,
                                       const SceneBuffers& buffers, bvh::BlockedBvh tree);

}  // namespace rayclass::render
