#include "rayclass/render/kdtree_query.h"

#include "rayclass/bvh/leaf_blocks.h"
#include "walk_query.h"

namespace rayclass::render {

namespace {

// Rays per work-item of the kernels (RC_PACKET in cl/bvh.cl).
constexpr uint32_t kPacketRays = 16;

// The tree as cl/kdtree.cl walks it: every leaf's primitives in leaf blocks, the leaf naming
// its first block in place of its position in primIndex.
struct BlockedKdTree {
    std::vector<RcKdNode> nodes;
    std::vector<RcBvhLeafBlock8> blocks;
};

BlockedKdTree BlockLeaves(const accel::KdTree& tree, const scene::Scene& scene) {
    BlockedKdTree out{tree.nodes, {}};
    out.blocks.reserve(tree.primIndex.size() / 4 + 1);
    for (RcKdNode& node : out.nodes) {
        if ((node.word & 3u) != RC_KD_LEAF) continue;
        const uint32_t count = node.word >> 2;
        const std::span<const uint32_t> prims(tree.primIndex.data() + node.data, count);
        node.data = uint32_t(out.blocks.size());
        bvh::AppendBlocks(prims, scene, out.blocks);
    }
    return out;
}

class KdTreeQuery final : public WalkQuery {
  public:
    KdTreeQuery(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene,
                const accel::KdTree& tree, const BlockedKdTree& blocked)
        : WalkQuery(ctx, program, scene, "kdtree", "nodes_visited",
                    {{"kdtree_nodes", double(tree.nodes.size())},
                     {"kdtree_leaves", double(tree.leaves)},
                     {"kdtree_empty_leaves", double(tree.emptyLeaves)},
                     {"kdtree_references", double(tree.primIndex.size())},
                     {"kdtree_bytes", double(tree.Bytes())},
                     {"kdtree_max_depth", double(tree.maxDepth)},
                     {"kdtree_blocks", double(blocked.blocks.size())}},
                    kPacketRays),
          nodes_(UploadVector(ctx, blocked.nodes)),
          blocks_(UploadVector(ctx, blocked.blocks)),
          boxLo_{tree.box.lo.x, tree.box.lo.y, tree.box.lo.z, tree.pad},
          boxHi_{tree.box.hi.x, tree.box.hi.y, tree.box.hi.z, 0.0f} {}

  private:
    void Bind(cl::Kernel& kernel, const cl::Buffer& rays, uint32_t n, const cl::Buffer& out,
              const cl::Buffer& counters) override {
        SetArgs(kernel, rays, n, nodes_, blocks_, boxLo_, boxHi_, scene_.triangles, scene_.spheres,
                scene_.quadrics, scene_.params, out, counters);
    }

    cl::Buffer nodes_, blocks_;
    cl_float4 boxLo_, boxHi_;
};

}  // namespace

std::unique_ptr<RayQuery> MakeKdTreeQuery(clrt::Context& ctx, const cl::Program& program,
                                          const SceneBuffers& buffers, const scene::Scene& scene,
                                          const accel::KdBuildParams& params) {
    const accel::KdTree tree = accel::BuildKdTree(scene, params);
    return std::make_unique<KdTreeQuery>(ctx, program, buffers, tree, BlockLeaves(tree, scene));
}

}  // namespace rayclass::render
