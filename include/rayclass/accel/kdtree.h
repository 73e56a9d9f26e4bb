// A kd-tree over the scene's primitives built with the surface area heuristic in O(N log N) by
// sorting split events once and keeping them sorted down the tree (Wald & Havran 2006), with
// the empty-space bonus, and with every primitive clipped to the node it is split into, so a
// triangle reaches only the leaves its surface crosses. cl/kdtree.cl walks it with a stack
// (--accel kdtree).
//
// Robustness: every primitive's extent in a node is padded by `pad` on each side before it is
// compared with a split plane, so a primitive lies in every leaf whose cell comes within `pad`
// of it (a float hit just outside a triangle still finds it), and the kernel widens every ray
// interval by more than float rounding can move it, so its walk never skips a leaf the ray
// touches.
#pragma once

#include <cstdint>
#include <vector>

#include "rayclass/core/bounds.h"
#include "rayclass/scene/scene.h"
#include "rc_types.h"

namespace rayclass::accel {

struct KdBuildParams {
    float traversalCost = 1.0f;  // cost of one node step
    float intersectCost = 4.0f;  // cost of one primitive test
    float emptyBonus = 0.8f;     // share of the cost a split cutting off empty space saves
    uint32_t maxDepth = 0;       // 0: 8 + 1.5 log2 N, at most kKdMaxDepth - 1
};

// The traversal kernel's stack holds one entry per level (RC_KD_STACK in cl/kdtree.cl).
constexpr uint32_t kKdMaxDepth = 64;

struct KdTree {
    std::vector<RcKdNode> nodes;      // nodes[0] is the root; depth first, lower child next
    std::vector<uint32_t> primIndex;  // leaves' global primitive ids, ascending within a leaf
    Bounds3f box;                     // the root cell: the scene box, padded
    float pad = 0;                    // see above
    uint32_t maxDepth = 0;            // deepest leaf (root = 0)
    uint32_t leaves = 0, emptyLeaves = 0;

    size_t Bytes() const {
        return nodes.size() * sizeof(RcKdNode) + primIndex.size() * sizeof(uint32_t);
    }
};

// Builds over every primitive of the scene (global ids); pad = 1e-6 of the scene box's diagonal.
// Fails (std::runtime_error) on more primitive references than a node can address.
KdTree BuildKdTree(const scene::Scene& scene, const KdBuildParams& params = {});

}  // namespace rayclass::accel
