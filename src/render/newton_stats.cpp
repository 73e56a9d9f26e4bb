#include "rayclass/render/newton_stats.h"

#include <array>

#include "rayclass/render/launch.h"

namespace rayclass::render {

namespace {

// cl/patch_stats.cl's counters, in order.
constexpr size_t kCounters = 11;

}  // namespace

std::map<std::string, double> NewtonCounts::ToStats() const {
    return {{"rays", double(rays)},
            {"tests", double(tests)},
            {"steps", double(steps)},
            {"steps_per_test", tests ? double(steps) / double(tests) : 0.0},
            {"culled", double(culled)},
            {"converged", double(converged)},
            {"diverged", double(diverged)},
            {"left_box", double(left)},
            {"on_cap", double(onCap)},
            {"hits", double(hits)},
            {"restarted", double(restarted)},
            {"restart_steps", double(restartSteps)},
            {"restart_hits", double(restartHits)}};
}

NewtonCounts CountNewton(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene,
                         uint32_t nAnalytic, const std::vector<RcRay>& rays) {
    NewtonCounts counts;
    counts.rays = rays.size();
    if (rays.empty()) return counts;
    const cl::Buffer rayBuffer = UploadVector(ctx, rays);
    std::array<uint32_t, kCounters> c{};
    const cl::Buffer counters = clrt::Check("clCreateBuffer", [&] {
        return cl::Buffer(ctx.context(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR, sizeof c,
                          c.data());
    });
    cl::Kernel kernel =
        clrt::Check("clCreateKernel", [&] { return cl::Kernel(program, "rc_patch_newton_stats"); });
    SetArgs(kernel, rayBuffer, uint32_t(rays.size()), scene.quadrics, nAnalytic, counters);
    KernelTimer timer;
    Launch(ctx, kernel, rays.size(), timer);
    clrt::Check("clEnqueueReadBuffer", [&] {
        return ctx.queue().enqueueReadBuffer(counters, CL_TRUE, 0, sizeof c, c.data());
    });
    counts.tests = c[0];
    counts.steps = c[1];
    counts.culled = c[2];
    counts.converged = c[3];
    counts.diverged = c[4];
    counts.left = c[5];
    counts.onCap = c[6];
    counts.hits = c[7];
    counts.restarted = c[8];
    counts.restartSteps = c[9];
    counts.restartHits = c[10];
    return counts;
}

void NewtonSampler::Sample(const cl::Buffer& rays, uint32_t n) {
    if (n == 0) return;
    const uint32_t stride = (n + sampleRays_ - 1) / sampleRays_;
    const uint32_t count = (n + stride - 1) / stride;
    std::vector<RcRay>& chunk = chunks_.emplace_back(count);
    const cl::array<size_t, 3> origin{0, 0, 0}, region{sizeof(RcRay), count, 1};
    clrt::Check("clEnqueueReadBufferRect", [&] {
        return ctx_.queue().enqueueReadBufferRect(rays, CL_FALSE, origin, origin, region,
                                                  size_t(stride) * sizeof(RcRay), 0, sizeof(RcRay),
                                                  0, chunk.data());
    });
}

NewtonCounts NewtonSampler::Count() {
    clrt::Check("clFinish", [&] { return ctx_.queue().finish(); });
    std::vector<RcRay> all;
    for (const auto& chunk : chunks_) all.insert(all.end(), chunk.begin(), chunk.end());
    return CountNewton(ctx_, program_, scene_, nAnalytic_, all);
}

}  // namespace rayclass::render
