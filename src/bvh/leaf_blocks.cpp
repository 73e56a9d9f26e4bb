#include "rayclass/bvh/leaf_blocks.h"

#include <bit>
#include <stdexcept>
#include <string>

namespace rayclass::bvh {

namespace {

// Lane `lane` of the run at `run` of a leaf of `count` primitives holds primitive `prim`: its
// vertex and edges when it is a triangle (the edges rounded as rc_intersect_triangle rounds
// them), zeros otherwise.
void SetLane(uint32_t* run, uint32_t count, uint32_t lane, uint32_t prim,
             const scene::Scene& scene) {
    run[(RC_BVH_LEAF_ARRAYS - 1) * count + lane] = prim;
    if (prim >= scene.triangles.size()) return;
    const auto& p = scene.triangles[prim].p;
    const float values[RC_BVH_LEAF_ARRAYS - 1] = {
        p[0].x,          p[0].y,          p[0].z,          p[1].x - p[0].x, p[1].y - p[0].y,
        p[1].z - p[0].z, p[2].x - p[0].x, p[2].y - p[0].y, p[2].z - p[0].z};
    for (uint32_t a = 0; a + 1 < RC_BVH_LEAF_ARRAYS; ++a)
        run[a * count + lane] = std::bit_cast<uint32_t>(values[a]);
}

// Words of the leaf arrays of `nodes`: each leaf's run rounded up to RC_BVH_LEAF_ALIGN, and the
// tail.
size_t LeafWords(const std::vector<RcBvh8Node>& nodes) {
    size_t words = RC_BVH_LEAF_TAIL;
    for (const RcBvh8Node& node : nodes) {
        for (uint32_t c = 0; c < node.nChildren; ++c) {
            const uint32_t ref = node.child[c];
            if (!(ref & RC_BVH8_LEAF)) continue;
            const uint32_t count = ((ref & ~RC_BVH8_LEAF) >> RC_BVH8_COUNT_SHIFT) + 1;
            words += (RC_BVH_LEAF_ARRAYS * count + RC_BVH_LEAF_ALIGN - 1) / RC_BVH_LEAF_ALIGN *
                     RC_BVH_LEAF_ALIGN;
        }
    }
    return words;
}

}  // namespace

BlockedBvh BlockLeaves(std::vector<RcBvh8Node> nodes, std::span<const uint32_t> primIndex,
                       const scene::Scene& scene) {
    BlockedBvh out;
    // Reserved exactly: growing the array on the way would copy it into fresh pages.
    out.leaves.reserve(LeafWords(nodes));
    for (RcBvh8Node& node : nodes) {
        for (uint32_t c = 0; c < node.nChildren; ++c) {
            const uint32_t ref = node.child[c];
            if (!(ref & RC_BVH8_LEAF)) continue;
            const uint32_t first = ref & RC_BVH8_FIRST_MASK;
            const uint32_t count = ((ref & ~RC_BVH8_LEAF) >> RC_BVH8_COUNT_SHIFT) + 1;
            const size_t at = out.leaves.size() / RC_BVH_LEAF_ALIGN;
            if (at > RC_BVH8_FIRST_MASK)
                throw std::runtime_error(
                    "bvh: more leaf words than the kernels can address (" +
                    std::to_string(size_t(RC_BVH8_FIRST_MASK + 1) * RC_BVH_LEAF_ALIGN) + ")");
            const size_t words = RC_BVH_LEAF_ARRAYS * count;
            out.leaves.resize(out.leaves.size() + (words + RC_BVH_LEAF_ALIGN - 1) /
                                                      RC_BVH_LEAF_ALIGN * RC_BVH_LEAF_ALIGN);
            uint32_t* run = out.leaves.data() + at * RC_BVH_LEAF_ALIGN;
            for (uint32_t k = 0; k < count; ++k)
                SetLane(run, count, k, primIndex[first + k], scene);
            node.child[c] = (ref & ~RC_BVH8_FIRST_MASK) | uint32_t(at);
        }
    }
    out.leaves.resize(out.leaves.size() + RC_BVH_LEAF_TAIL);
    out.nodes = std::move(nodes);
    return out;
}

}  // namespace rayclass::bvh
