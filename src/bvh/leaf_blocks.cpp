#include "rayclass/bvh/leaf_blocks.h"

#include <stdexcept>
#include <string>

namespace rayclass::bvh {

namespace {

// Lane `lane` of `block` holds primitive `prim`: its vertex and edges when it is a triangle
// (the edges rounded as rc_intersect_triangle rounds them), zeros otherwise.
void SetLane(RcBvhLeafBlock8& block, uint32_t lane, uint32_t prim, const scene::Scene& scene) {
    block.prim[lane] = prim;
    if (prim >= scene.triangles.size()) return;
    const auto& p = scene.triangles[prim].p;
    block.v0x[lane] = p[0].x;
    block.v0y[lane] = p[0].y;
    block.v0z[lane] = p[0].z;
    block.e1x[lane] = p[1].x - p[0].x;
    block.e1y[lane] = p[1].y - p[0].y;
    block.e1z[lane] = p[1].z - p[0].z;
    block.e2x[lane] = p[2].x - p[0].x;
    block.e2y[lane] = p[2].y - p[0].y;
    block.e2z[lane] = p[2].z - p[0].z;
}

RcBvhLeafBlock8 EmptyBlock() {
    RcBvhLeafBlock8 block{};
    for (uint32_t& prim : block.prim) prim = RC_NO_HIT;
    return block;
}

}  // namespace

BlockedBvh BlockLeaves(std::vector<RcBvh8Node> nodes, std::span<const uint32_t> primIndex,
                       const scene::Scene& scene) {
    BlockedBvh out;
    out.blocks.reserve(primIndex.size() / 4 + 1);
    for (RcBvh8Node& node : nodes) {
        for (uint32_t c = 0; c < node.nChildren; ++c) {
            const uint32_t ref = node.child[c];
            if (!(ref & RC_BVH8_LEAF)) continue;
            const uint32_t first = ref & RC_BVH8_FIRST_MASK;
            const uint32_t count = ((ref & ~RC_BVH8_LEAF) >> RC_BVH8_COUNT_SHIFT) + 1;
            const size_t block = out.blocks.size();
            if (block + (count + 7) / 8 > size_t(RC_BVH8_FIRST_MASK) + 1)
                throw std::runtime_error("bvh: more leaf blocks than the kernels can address (" +
                                         std::to_string(RC_BVH8_FIRST_MASK + 1) + ")");
            for (uint32_t k = 0; k < count; ++k) {
                if (k % 8 == 0) out.blocks.push_back(EmptyBlock());
                SetLane(out.blocks.back(), k % 8, primIndex[first + k], scene);
            }
            node.child[c] = (ref & ~RC_BVH8_FIRST_MASK) | uint32_t(block);
        }
    }
    out.nodes = std::move(nodes);
    return out;
}

void AppendBlocks(std::span<const uint32_t> prims, const scene::Scene& scene,
                  std::vector<RcBvhLeafBlock8>& blocks) {
    for (size_t k = 0; k < prims.size(); ++k) {
        if (k % 8 == 0) blocks.push_back(EmptyBlock());
        SetLane(blocks.back(), uint32_t(k % 8), prims[k], scene);
    }
}

}  // namespace rayclass::bvh
