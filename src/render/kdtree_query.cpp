#include "rayclass/render/kdtree_query.h"

#include "ray_counters.h"
#include "rayclass/render/launch.h"

namespace rayclass::render {

namespace {

class KdTreeQuery final : public RayQuery {
  public:
    KdTreeQuery(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene,
                const accel::KdTree& tree)
        : ctx_(ctx),
          scene_(scene),
          nodes_(UploadVector(ctx, tree.nodes)),
          primIndex_(UploadVector(ctx, tree.primIndex)),
          boxLo_{tree.box.lo.x, tree.box.lo.y, tree.box.lo.z, tree.pad},
          boxHi_{tree.box.hi.x, tree.box.hi.y, tree.box.hi.z, 0.0f},
          intersect_(program, "rc_intersect_kdtree"),
          occluded_(program, "rc_occluded_kdtree") {
        stats_.accel = {{"kdtree_nodes", double(tree.nodes.size())},
                        {"kdtree_leaves", double(tree.leaves)},
                        {"kdtree_empty_leaves", double(tree.emptyLeaves)},
                        {"kdtree_references", double(tree.primIndex.size())},
                        {"kdtree_bytes", double(tree.Bytes())},
                        {"kdtree_max_depth", double(tree.maxDepth)},
                        {"kdtree_rays", 0.0},
                        {"kdtree_nodes_visited", 0.0}};
    }

    std::string Name() const override { return "kdtree"; }
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

  private:
    uint64_t Run(cl::Kernel& kernel, const cl::Buffer& rays, uint32_t n, const cl::Buffer& out,
                 KernelTimer& timer) {
        if (n == 0) return 0;
        SetArgs(kernel, rays, n, nodes_, primIndex_, boxLo_, boxHi_, scene_.triangles,
                scene_.spheres, scene_.quadrics, scene_.params, out, counters_.Reserve(ctx_, n));
        Launch(ctx_, kernel, n, timer);
        const CounterSums sums = counters_.Sum(ctx_, n);
        stats_.accel["kdtree_rays"] += n;
        stats_.accel["kdtree_nodes_visited"] += double(sums.steps);
        return sums.tests;
    }

    clrt::Context& ctx_;
    const SceneBuffers& scene_;
    cl::Buffer nodes_, primIndex_;
    cl_float4 boxLo_, boxHi_;
    cl::Kernel intersect_, occluded_;
    RayCounters counters_;
    QueryStats stats_;
};

}  // namespace

std::unique_ptr<RayQuery> MakeKdTreeQuery(clrt::Context& ctx, const cl::Program& program,
                                          const SceneBuffers& buffers, const scene::Scene& scene,
                                          const accel::KdBuildParams& params) {
    return std::make_unique<KdTreeQuery>(ctx, program, buffers, accel::BuildKdTree(scene, params));
}

}  // namespace rayclass::render
