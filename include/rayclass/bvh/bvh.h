// A bounding volume hierarchy over the scene's primitives, built on the host as a binary tree with
// the binned surface area heuristic (Wald 2007), then collapsed to eight children per node
// (RcBvh8Node, rc_types.h) for the stack-based traversal kernels of cl/bvh.cl (--accel bvh): the
// mainstream structure that ray classification is measured against.
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
    // Cost of one node visit relative to one primitive test: the kernels test a leaf's
    // triangles eight at a time (leaf_blocks.h) but wait on every node they visit, so a node
    // costs several primitives and leaves come out fuller.
    float traversalCost = 4.0f;
    uint32_t threads = 0;        // build threads (0: one per core); the tree does not depend on it
};

// A node of the binary tree, flattened depth first. count > 0: a leaf whose primitives' ids are
// primIndex[first, first + count); count == 0: an inner node whose children are nodes[self + 1]
// and nodes[first], split along `axis` (the child at self + 1 holds the lower centroids). The box
// is padded (see Build).
struct BinaryNode {
    Bounds3f box;
    uint32_t first = 0;
    uint32_t count = 0;
    uint32_t axis = 0;
};

struct Bvh {
    std::vector<BinaryNode> nodes;    // nodes[0] is the root
    std::vector<uint32_t> primIndex;  // leaves' global primitive ids
    uint32_t maxDepth = 0;            // deepest leaf (root = 0)
};

// Builds over boxes[i] (primitive i). Node boxes are the union of their primitives' boxes, padded
// outward by `pad` (absolute) plus a relative 2^-20 of each coordinate's magnitude.
Bvh Build(std::span<const Bounds3f> boxes, float pad, const BuildParams& params = {});

// Every primitive of the scene (global ids), padded by 1e-6 of the scene box's diagonal.
Bvh Build(const scene::Scene& scene, const BuildParams& params = {});

// Build fails (std::runtime_error) on a deeper tree: Collapse keeps a walk of the wide tree within
// kStackEntries, which it can as long as the binary tree is no deeper.
constexpr uint32_t kMaxDepth = 60;

// The traversal kernels' stack (RC_BVH_STACK in cl/bvh.cl). Eight children everywhere needed 89
// entries on Conference (binary depth 34); a smaller stack makes Collapse narrow nodes, and
// narrower nodes slow the traversal of eye and shadow rays.
constexpr uint32_t kStackEntries = 128;

// The SAH costs Collapse minimises, relative to a wide node's visit (one slab test of its eight
// boxes and the sort of those entered, cl/bvh.cl): a leaf's visit (a pop and its run's first
// cache lines) and each of its primitives (tested eight lanes at a time by one ray, but one at a
// time by a packet, whose nodes cost little more than one ray's).
constexpr float kWideNodeCost = 1.0f;
constexpr float kLeafCost = 0.2f;
constexpr float kLeafPrimCost = 0.6f;

// The binary tree collapsed to nodes of up to eight children, nodes[0] the root, over the same
// primIndex: the collapse of least SAH cost (Ylitie, Karras and Laine 2017), whose leaves are
// binary leaves or whole subtrees of at most RC_BVH8_MAX_LEAF primitives (one run of primIndex,
// as Build's depth-first trees give). Where its walks could push more than `stackEntries`
// entries, a node takes instead the children of its binary node, then repeatedly replaces the
// inner child of the largest surface with that child's two children, and has fewer children
// where more would let a walk push more than `stackEntries` entries. Fails (std::runtime_error)
// on a binary leaf of more than RC_BVH8_MAX_LEAF primitives, on more than RC_BVH8_FIRST_MASK + 1
// primitives and on a tree higher than `stackEntries` (Build's trees are at most kMaxDepth high).
std::vector<RcBvh8Node> Collapse(const Bvh& tree, uint32_t stackEntries = kStackEntries);

}  // namespace rayclass::bvh
