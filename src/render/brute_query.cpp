#include "rayclass/render/brute_query.h"

#include <vector>

namespace rayclass::render {

namespace {

class BruteForceQuery final : public RayQuery {
  public:
    BruteForceQuery(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene)
        : ctx_(ctx),
          scene_(scene),
          intersect_(program, "rc_intersect_brute"),
          occluded_(program, "rc_occluded_brute") {}

    std::string Name() const override { return "brute"; }

    QueryResult Intersect(const cl::Buffer& rays, uint32_t n, const PreparedBatch*,
                          const cl::Buffer& hits, const ShadeBuffers&,
                          KernelTimer& timer) override {
        SetArgs(intersect_, rays, n, scene_.triangles, scene_.spheres, scene_.quadrics,
                scene_.params, hits);
        Launch(ctx_, intersect_, n, timer);
        const auto& p = scene_.hostParams;
        return {uint64_t(n) * (p.nTriangles + p.nSpheres + p.nQuadrics), false};
    }

    uint64_t Occluded(const cl::Buffer& shadowRays, std::span<const RcRay> hostRays,
                      const cl::Buffer& blocked, KernelTimer& timer) override {
        const uint32_t n = uint32_t(hostRays.size());
        const cl::Buffer& tests = testsBuffer_.Reserve(ctx_, n * sizeof(uint32_t));
        SetArgs(occluded_, shadowRays, n, scene_.triangles, scene_.spheres, scene_.quadrics,
                scene_.params, blocked, tests);
        Launch(ctx_, occluded_, n, timer);
        return SumCounters(ctx_, tests, n, tests_);
    }

  private:
    clrt::Context& ctx_;
    const SceneBuffers& scene_;
    cl::Kernel intersect_, occluded_;
    GrowingBuffer testsBuffer_;
    std::vector<uint32_t> tests_;
};

}  // namespace

std::unique_ptr<RayQuery> MakeBruteForceQuery(clrt::Context& ctx, const cl::Program& program,
                                              const SceneBuffers& scene) {
    return std::make_unique<BruteForceQuery>(ctx, program, scene);
}

}  // namespace rayclass::render
