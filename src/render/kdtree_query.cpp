#include "rayclass/render/kdtree_query.h"

#include "walk_query.h"

namespace rayclass::render {

namespace {

class KdTreeQuery final : public WalkQuery {
  public:
    KdTreeQuery(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene,
                const accel::KdTree& tree)
        : WalkQuery(ctx, program, scene, "kdtree", "nodes_visited",
                    {{"kdtree_nodes", double(tree.nodes.size())},
                     {"kdtree_leaves", double(tree.leaves)},
                     {"kdtree_empty_leaves", double(tree.emptyLeaves)},
                     {"kdtree_references", double(tree.primIndex.size())},
                     {"kdtree_bytes", double(tree.nodes.size() * sizeof(RcKdNode) +
                                             tree.primIndex.size() * sizeof(uint32_t))},
                     {"kdtree_max_depth", double(tree.maxDepth)}},
                    kPacketRays),
          nodes_(UploadVector(ctx, tree.nodes)),
          prims_(UploadVector(ctx, tree.primIndex)),
          boxLo_{{tree.box.lo.x, tree.box.lo.y, tree.box.lo.z, tree.pad}},
          boxHi_{{tree.box.hi.x, tree.box.hi.y, tree.box.hi.z, 0.0f}} {}

  private:
    void Bind(cl::Kernel& kernel, const cl::Buffer& rays, uint32_t n, const cl::Buffer& out,
              const cl::Buffer& counters) override {
        SetArgs(kernel, rays, n, nodes_, prims_, boxLo_, boxHi_, scene_.triangles, scene_.spheres,
                scene_.quadrics, scene_.params, out, counters);
    }

    cl::Buffer nodes_, prims_;
    cl_float4 boxLo_, boxHi_;
};

}  // namespace

std::unique_ptr<RayQuery> MakeKdTreeQuery(clrt::Context& ctx, const cl::Program& program,
                                          const SceneBuffers& buffers, const scene::Scene& scene,
                                          const accel::KdBuildParams& params) {
    const accel::KdTree tree = accel::BuildKdTree(scene, params);
    return std::make_unique<KdTreeQuery>(ctx, program, buffers, tree);
}

}  // namespace rayclass::render
