// A query whose two kernels walk one structure ray by ray (the kd-tree's, the grid's): each batch
// is one launch of rc_intersect_NAME or rc_occluded_NAME, and the per-ray counters add up into the
// stats keys NAME_rays and NAME_STEPS (the structure's own steps: nodes or cells visited). A
// work-item answers raysPerItem consecutive rays.
#pragma once

#include <map>
#include <string>

#include "ray_counters.h"
#include "rayclass/render/launch.h"
#include "rayclass/render/ray_query.h"

namespace rayclass::render {

class WalkQuery : public RayQuery {
  public:
    std::string Name() const override { return name_; }
    QueryStats Stats() const override { return stats_; }

    QueryResult Intersect(const cl::Buffer& rays, uint32_t n, const PreparedBatch*,
                          const cl::Buffer& hits, const ShadeBuffers&,
                          KernelTimer& timer) override {
        return {Run(intersect_, rays, n, hits, timer), false};
    }

    uint64_t Occluded(const cl::Buffer& shadowRays, std::span<const RcRay> hostRays,
                      const cl::Buffer& blocked, KernelTimer& timer) override {
        return Run(occluded_, shadowRays, uint32_t(hostRays.size()), blocked, timer);
    }

  protected:
    // `structure`: the structure's size figures, reported as they are.
    WalkQuery(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene,
              const std::string& name, const std::string& steps,
              std::map<std::string, double> structure, uint32_t raysPerItem = 1)
        : ctx_(ctx),
          scene_(scene),
          name_(name),
          raysKey_(name + "_rays"),
          stepsKey_(name + "_" + steps),
          intersect_(program, ("rc_intersect_" + name).c_str()),
          occluded_(program, ("rc_occluded_" + name).c_str()),
          raysPerItem_(raysPerItem) {
        stats_.accel = std::move(structure);
        stats_.accel[raysKey_] = 0.0;
        stats_.accel[stepsKey_] = 0.0;
    }

    // Sets every argument of `kernel` for a batch of n rays writing to `out`.
    virtual void Bind(cl::Kernel& kernel, const cl::Buffer& rays, uint32_t n, const cl::Buffer& out,
                      const cl::Buffer& counters) = 0;

    clrt::Context& ctx_;
    const SceneBuffers& scene_;

  private:
    uint64_t Run(cl::Kernel& kernel, const cl::Buffer& rays, uint32_t n, const cl::Buffer& out,
                 KernelTimer& timer) {
        if (n == 0) return 0;
        Bind(kernel, rays, n, out, counters_.Reserve(ctx_, n));
        Launch(ctx_, kernel, (n + raysPerItem_ - 1) / raysPerItem_, timer);
        const CounterSums sums = counters_.Sum(ctx_, n);
        stats_.accel[raysKey_] += n;
        stats_.accel[stepsKey_] += double(sums.steps);
        return sums.tests;
    }

    std::string name_, raysKey_, stepsKey_;
    cl::Kernel intersect_, occluded_;
    uint32_t raysPerItem_;
    RayCounters counters_;
    QueryStats stats_;
};

}  // namespace rayclass::render
