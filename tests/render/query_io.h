// Running a RayQuery on a host vector of rays, as the renderer runs it, for the render module's
// suites: the batch prepared and its nearest hits shaded, or its any-hit answers.
#pragma once

#include <memory>
#include <vector>

#include "rayclass/clrt/context.h"
#include "rayclass/render/ray_query.h"
#include "rayclass/render/launch.h"

namespace rayclass::render {

// Nearest hits of `rays` as eye rays (shaded with `nLights` lights); returns the tests done and,
// where hitsOut is given, the hits.
inline uint64_t NearestHits(clrt::Context& ctx, RayQuery& q, const std::vector<RcRay>& rays,
                            uint32_t nLights, std::vector<RcHit>* hitsOut) {
    const uint32_t n = uint32_t(rays.size());
    std::vector<RcRayInfo> info(n);
    for (uint32_t i = 0; i < n; ++i) {
        info[i].weight = {1.0f, 1.0f, 1.0f, 0.0f};
        info[i].kind = RC_RAY_EYE;
    }
    const cl::Buffer rayBuf = UploadVector(ctx, rays);
    const cl::Buffer hits(ctx.context(), CL_MEM_READ_WRITE, n * sizeof(RcHit));
    ShadeBuffers shade = MakeShadeBuffers(ctx, n, nLights);
    shade.rayInfo = UploadVector(ctx, info);
    KernelTimer timer;
    std::unique_ptr<PreparedBatch> prepared = q.Prepare(rayBuf, n, ctx.queue(), {});
    const uint64_t tests = q.Intersect(rayBuf, n, prepared.get(), hits, shade, timer).tests;
    q.Recycle(std::move(prepared));
    if (hitsOut) {
        hitsOut->resize(n);
        ctx.queue().enqueueReadBuffer(hits, CL_TRUE, 0, n * sizeof(RcHit), hitsOut->data());
    }
    ctx.queue().finish();
    return tests;
}

inline std::vector<RcHit> NearestHits(clrt::Context& ctx, RayQuery& q,
                                      const std::vector<RcRay>& rays) {
    std::vector<RcHit> hits;
    NearestHits(ctx, q, rays, 0, &hits);
    return hits;
}

// Whether each of `rays` is blocked before its tmax; *tests, where given, the tests done.
inline std::vector<uint8_t> BlockedAnswers(clrt::Context& ctx, RayQuery& q,
                                           const std::vector<RcRay>& rays,
                                           uint64_t* tests = nullptr) {
    const uint32_t n = uint32_t(rays.size());
    const cl::Buffer blocked(ctx.context(), CL_MEM_READ_WRITE, n);
    KernelTimer timer;
    const uint64_t done = q.Occluded(UploadVector(ctx, rays), rays, blocked, timer);
    if (tests) *tests = done;
    std::vector<uint8_t> out(n);
    ctx.queue().enqueueReadBuffer(blocked, CL_TRUE, 0, n, out.data());
    return out;
}

}  // namespace rayclass::render
