// The 8-wide hierarchy in the form cl/bvh.cl walks it: every leaf's primitives copied into a run
// of words sized to the leaf (rc_types.h, RC_BVH_LEAF_ARRAYS), so that the kernel tests a leaf's
// triangles with float8 tests, reads them from one place and fetches only the cache lines they
// fill.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rayclass/scene/scene.h"
#include "rc_types.h"

namespace rayclass::bvh {

struct BlockedBvh {
    // Collapse's nodes, each leaf reference RC_BVH8_LEAF | (count - 1) << RC_BVH8_COUNT_SHIFT |
    // first naming the leaf's run: its count primitives, in primIndex order, fill the arrays of
    // leaves[first * RC_BVH_LEAF_ALIGN, first * RC_BVH_LEAF_ALIGN + RC_BVH_LEAF_ARRAYS * count).
    std::vector<RcBvh8Node> nodes;
    std::vector<uint32_t> leaves;
};

// `nodes` (Collapse's, whose leaves name positions in `primIndex`) over the primitives of
// `scene` (global ids). Fails (std::runtime_error) when a run starts beyond what a leaf
// reference can address (RC_BVH8_FIRST_MASK).
BlockedBvh BlockLeaves(std::vector<RcBvh8Node> nodes, std::span<const uint32_t> primIndex,
                       const scene::Scene& scene);

}  // namespace rayclass::bvh
