#include "rayclass/render/bvh_query.h"

#include <chrono>
#include <utility>

#include "rayclass/bvh/leaf_blocks.h"
#include "rayclass/render/launch.h"
#include "shadow_order.h"

namespace rayclass::render {

namespace {

// Shadow rays are sorted by direction from their light (ShadowOrder) when more than this share
// of their packets would not walk as one in their own order.
constexpr double kSortShare = 0.2;

// The box of the tree's root.
Bounds3f RootBox(const bvh::BlockedBvh& tree) {
    Bounds3f box;
    if (tree.nodes.empty()) return box;
    const RcBvh8Node& root = tree.nodes[0];
    for (uint32_t c = 0; c < root.nChildren; ++c) {
        box.Grow(glm::vec3(root.loX[c], root.loY[c], root.loZ[c]));
        box.Grow(glm::vec3(root.hiX[c], root.hiY[c], root.hiZ[c]));
    }
    return box;
}

class BvhQuery final : public RayQuery {
  public:
    BvhQuery(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene,
             bvh::BlockedBvh tree)
        : ctx_(ctx),
          scene_(scene),
          tree_(std::move(tree)),
          nodes_(ReadOnlyView(ctx, tree_.nodes)),
          leaves_(ReadOnlyView(ctx, tree_.leaves)),
          bytes_(double(tree_.nodes.size() * sizeof(RcBvh8Node) +
                        tree_.leaves.size() * sizeof(uint32_t))),
          intersect_(program, "rc_intersect_bvh"),
          occluded_(program, "rc_occluded_bvh"),
          shadowOrder_(RootBox(tree_)) {}

    std::string Name() const override { return "bvh"; }

    QueryStats Stats() const override {
        QueryStats stats;
        stats.accel["bvh_bytes"] = bytes_;
        return stats;
    }

    QueryResult Intersect(const cl::Buffer& rays, uint32_t n, const PreparedBatch*,
                          const cl::Buffer& hits, const ShadeBuffers&,
                          KernelTimer& timer) override {
        Run(intersect_, rays, n, hits, timer);
        return {SumTests(n), false};
    }

    uint64_t Occluded(const cl::Buffer& shadowRays, std::span<const RcRay> hostRays,
                      const cl::Buffer& blocked, KernelTimer& timer) override {
        const uint32_t n = uint32_t(hostRays.size());
        if (n == 0) return 0;
        // Rays in an order of their own that keeps most packets coherent (eye hits in pixel
        // tiles) walk in it: their packets are narrower than those of direction cells.
        const bool sort = shadowOrder_.IncoherentShare(hostRays) > kSortShare;
        const cl::Buffer order =
            sort ? orderBuffer_.Share(ctx_, shadowOrder_.Sort(hostRays)) : cl::Buffer();
        SetArgs(occluded_, shadowRays, order, n, nodes_, leaves_, scene_.triangles, scene_.spheres,
                scene_.quadrics, scene_.params, blocked,
                testsBuffer_.Reserve(ctx_, n * sizeof(uint32_t)));
        Launch(ctx_, occluded_, PacketItems(n), timer);
        return SumTests(n);
    }

  private:
    void Run(cl::Kernel& kernel, const cl::Buffer& rays, uint32_t n, const cl::Buffer& out,
             KernelTimer& timer) {
        if (n == 0) return;
        SetArgs(kernel, rays, n, nodes_, leaves_, scene_.triangles, scene_.spheres, scene_.quadrics,
                scene_.params, out, testsBuffer_.Reserve(ctx_, n * sizeof(uint32_t)));
        Launch(ctx_, kernel, PacketItems(n), timer);
    }

    uint64_t SumTests(uint32_t n) {
        return SumCounters(ctx_, testsBuffer_.Reserve(ctx_, n * sizeof(uint32_t)), n, tests_);
    }

    clrt::Context& ctx_;
    const SceneBuffers& scene_;
    const bvh::BlockedBvh tree_;  // what nodes_ and leaves_ may read in place
    cl::Buffer nodes_, leaves_;
    double bytes_;
    cl::Kernel intersect_, occluded_;
    GrowingBuffer testsBuffer_, orderBuffer_;
    std::vector<uint32_t> tests_;
    ShadowOrder shadowOrder_;
};

bvh::BlockedBvh BuildBlocked(const scene::Scene& scene, const bvh::BuildParams& params) {
    const bvh::Bvh tree = bvh::Build(scene, params);
    return bvh::BlockLeaves(bvh::Collapse(tree), tree.primIndex, scene);
}

}  // namespace

std::unique_ptr<RayQuery> MakeBvhQuery(clrt::Context& ctx, const cl::Program& program,
                                       const SceneBuffers& buffers, const scene::Scene& scene,
                                       const bvh::BuildParams& params) {
    return MakeBvhQuery(ctx, program, buffers, BuildBlocked(scene, params));
}

std::unique_ptr<RayQuery> MakeBvhQuery(clrt::Context& ctx, const cl::Program& program,
                                       const SceneBuffers& buffers, bvh::BlockedBvh tree) {
    return std::make_unique<BvhQuery>(ctx, program, buffers, std::move(tree));
}

BvhBuild::BvhBuild(const scene::Scene& scene, const bvh::BuildParams& params)
    : result_(std::async(std::launch::async, [&scene, params] {
          const auto t0 = std::chrono::steady_clock::now();
          Result result{BuildBlocked(scene, params)};
          result.seconds =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          return result;
      })) {}

}  // namespace rayclass::render
