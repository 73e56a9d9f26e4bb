// A bounding volume hierarchy over the scene's primitives, built on the host with the binned
// surface area heuristic (Wald 2007) and flattened depth-first into RcBvhNode (rc_types.h) for the
// stack-based traversal kernels of cl/bvh.cl (--accel bvh): the mainstream structure that ray
// classification is measured against.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rayclass/core/bounds.h"
#include "rayclass/scene/scene.h"
#include "rc_types.h"

namespace rayclass::bvh {

struct BuildParams {
    uint32_t bins = 32;          // SAH bins per axis
    uint32_t maxLeafSize = 8;    // a node with more primitives is always split
    float traversalCost = 1.0f;  // cost of one node visit relative to one primitive test
    uint32_t threads = 0;        // build threads (0: one per core); the tree does not depend on it
};

struct Bvh {
    std::vector<RcBvhNode> nodes;     // nodes[0] is the root
    std::vector<uint32_t> primIndex;  // leaves' global primitive ids
    uint32_t maxDepth = 0;            // deepest leaf (root = 0)
};

// Builds over boxes[i] (primitive i). Node boxes are the union of their primitives' boxes, padded
// outward by `pad` (absolute) plus a relative 2^-20 of each coordinate's magnitude.
Bvh Build(std::span<const Bounds3f> boxes, float pad, const BuildParams& params = {});

// Every primitive of the scene (global ids), padded by 1e-6 of the scene box's diagonal.
Bvh Build(const scene::Scene& scene, const BuildParams& params = {});

// The traversal kernels' stack depth; Build fails (std::runtime_error) on a deeper tree.
constexpr uint32_t kMaxDepth = 60;

}  // namespace rayclass::bvh
