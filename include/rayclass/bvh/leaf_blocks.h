// The 8-wide hierarchy in the form cl/bvh.cl walks it: every leaf's primitives copied into blocks
// of eight lanes (RcBvhLeafBlock8), so that the kernel tests a leaf's triangles with one float8
// test per block instead of one primitive at a time, and reads them from one place.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rayclass/scene/scene.h"
#include "rc_types.h"

namespace rayclass::bvh {

struct BlockedBvh {
    // Collapse's nodes, each leaf reference RC_BVH8_LEAF | (count - 1) << RC_BVH8_COUNT_SHIFT |
    // first naming the leaf's first block: its count primitives fill blocks[first, first +
    // ceil(count / 8)) in primIndex order, lane by lane.
    std::vector<RcBvh8Node> nodes;
    std::vector<RcBvhLeafBlock8> blocks;
};

// `nodes` (Collapse's, whose leaves name positions in `primIndex`) over the primitives of
// `scene` (global ids). Fails (std::runtime_error) when the blocks outnumber what a leaf
// reference can address (RC_BVH8_FIRST_MASK + 1).
BlockedBvh BlockLeaves(std::vector<RcBvh8Node> nodes, std::span<const uint32_t> primIndex,
                       const scene::Scene& scene);

// Appends blocks holding `prims` lane by lane, the last one's unused lanes empty (RC_NO_HIT):
// the leaves of the other hierarchies (the kd-tree's, the grid's cells) in the same form.
void AppendBlocks(std::span<const uint32_t> prims, const scene::Scene& scene,
                  std::vector<RcBvhLeafBlock8>& blocks);

}  // namespace rayclass::bvh
