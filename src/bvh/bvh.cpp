#include "rayclass/bvh/bvh.h"

#include <algorithm>
#include <array>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace rayclass::bvh {

namespace {

float HalfArea(const Bounds3f& b) {
    if (b.Empty()) return 0.0f;
    const glm::vec3 s = b.hi - b.lo;
    return s.x * s.y + s.y * s.z + s.z * s.x;
}

void SetChildBox(RcBvh8Node& node, uint32_t c, const Bounds3f& box) {
    node.loX[c] = box.lo.x;
    node.loY[c] = box.lo.y;
    node.loZ[c] = box.lo.z;
    node.hiX[c] = box.hi.x;
    node.hiY[c] = box.hi.y;
    node.hiZ[c] = box.hi.z;
}

float LeafCost(uint32_t count) { return kLeafCost + kLeafPrimCost * float(count); }

// Collapses binary subtrees into wide nodes, depth first (a node's index is below its children's).
// Each node's children are chosen by the SAH-optimal collapse of Ylitie, Karras and Laine (2017):
// per binary node the cheapest cost of its subtree as at most j = 1..8 subtrees, each a wide node
// or a leaf of a contiguous run of primIndex. Where that tree would let a walk push more than the
// stack holds, a node takes Expand's children instead.
struct Collapser {
    explicit Collapser(const Bvh& tree_)
        : tree(tree_),
          greedy(tree_.nodes.size(), 0),
          need(tree_.nodes.size(), 0),
          optimalNeed(tree_.nodes.size(), 0),
          cost(tree_.nodes.size()),
          share(tree_.nodes.size()),
          asLeaf(tree_.nodes.size(), 0),
          firstPrim(tree_.nodes.size(), 0),
          prims(tree_.nodes.size(), 0) {
        // Children come after their parent: bottom up is back to front.
        std::vector<uint32_t> height(tree.nodes.size(), 0);
        for (size_t b = tree.nodes.size(); b-- > 0;) {
            const BinaryNode& n = tree.nodes[b];
            // A tree without primitives is a single node of count 0 that has no children.
            if (tree.primIndex.empty()) continue;
            Optimise(uint32_t(b));
            if (n.count > 0) continue;
            height[b] = 1 + std::max(height[b + 1], height[n.first]);
            uint32_t child[8];
            const uint32_t k = Expand(uint32_t(b), child, ~0u);
            uint32_t below = 0;
            for (uint32_t c = 0; c < k; ++c) below = std::max(below, greedy[child[c]]);
            greedy[b] = k - 1 + below;
            need[b] = std::min(height[b], greedy[b]);
        }
    }

    const Bvh& tree;
    // Per binary node: the stack entries a walk of its wide subtree takes when every node has as
    // many children as Expand gives it without a budget, and the fewest it can be made to take,
    // the fewer of that and its height (two children everywhere).
    std::vector<uint32_t> greedy, need;
    // Per inner binary node: the entries a walk of its optimal wide node's subtree takes.
    std::vector<uint32_t> optimalNeed;
    // Per binary node: cost[b][j - 1], the cheapest SAH cost of its subtree as at most j subtrees,
    // and whether the cheapest as one is a leaf.
    std::vector<std::array<float, 8>> cost;
    // Per inner binary node: share[b][j - 1], its lower child's share of the cheapest split of
    // exactly j subtrees between its children (j >= 2).
    std::vector<std::array<uint8_t, 8>> share;
    std::vector<uint8_t> asLeaf;
    // Per binary node: its primitives are primIndex[firstPrim, firstPrim + prims), or prims is
    // ~0u where they do not form one run.
    std::vector<uint32_t> firstPrim, prims;
    std::vector<RcBvh8Node> nodes;

    // The cheapest of j subtrees of inner node b split between its children, and the split: the
    // lower child's share.
    std::pair<float, uint32_t> Split(uint32_t b, uint32_t j) const {
        const auto& lo = cost[b + 1];
        const auto& hi = cost[tree.nodes[b].first];
        std::pair<float, uint32_t> best{std::numeric_limits<float>::infinity(), 1};
        for (uint32_t k = 1; k < j; ++k) {
            const float c = lo[k - 1] + hi[j - k - 1];
            if (c < best.first) best = {c, k};
        }
        return best;
    }

    // Node b's costs, run and (inner) optimal stack entries, its children's being known.
    void Optimise(uint32_t b) {
        const BinaryNode& n = tree.nodes[b];
        const float area = HalfArea(n.box);
        if (n.count > 0) {
            firstPrim[b] = n.first;
            prims[b] = n.count;
            asLeaf[b] = 1;
            cost[b].fill(area * LeafCost(n.count));
            return;
        }
        const uint32_t lo = b + 1, hi = n.first;
        firstPrim[b] = firstPrim[lo];
        const bool run =
            prims[lo] != ~0u && prims[hi] != ~0u && firstPrim[hi] == firstPrim[lo] + prims[lo];
        prims[b] = run ? prims[lo] + prims[hi] : ~0u;
        float exactly[8];
        for (uint32_t j = 2; j <= 8; ++j) {
            const auto [c, k] = Split(b, j);
            exactly[j - 1] = c;
            share[b][j - 1] = uint8_t(k);
        }
        const float wide = area * kWideNodeCost + exactly[7];
        const float leaf = prims[b] <= RC_BVH8_MAX_LEAF ? area * LeafCost(prims[b])
                                                        : std::numeric_limits<float>::infinity();
        asLeaf[b] = leaf <= wide;
        cost[b][0] = std::min(leaf, wide);
        for (uint32_t j = 2; j <= 8; ++j) cost[b][j - 1] = std::min(cost[b][j - 2], exactly[j - 1]);
        uint32_t child[8];
        const uint32_t k = Distribute(b, 8, child, 0);
        uint32_t below = 0;
        for (uint32_t c = 0; c < k; ++c)
            if (!asLeaf[child[c]]) below = std::max(below, optimalNeed[child[c]]);
        optimalNeed[b] = k - 1 + below;
    }

    // The subtrees of node b as at most j roots of the optimal collapse, appended to child from
    // position k on. Returns the new count.
    uint32_t Slots(uint32_t b, uint32_t j, uint32_t* child, uint32_t k) const {
        if (j == 1 || cost[b][j - 1] == cost[b][0]) {
            child[k] = b;
            return k + 1;
        }
        return Distribute(b, j, child, k);
    }

    // Slots of inner node b's children, j between them.
    uint32_t Distribute(uint32_t b, uint32_t j, uint32_t* child, uint32_t k) const {
        const uint32_t lower = share[b][j - 1];
        k = Slots(b + 1, lower, child, k);
        return Slots(tree.nodes[b].first, j - lower, child, k);
    }

    // Inner node b's children in its wide node: its binary children, then the widest inner child
    // replaced by its two children while fewer than eight and while a walk below would push at
    // most `budget` entries. Returns their count.
    uint32_t Expand(uint32_t b, uint32_t* child, uint32_t budget) const {
        child[0] = b + 1;
        child[1] = tree.nodes[b].first;
        uint32_t n = 2;
        while (n < 8) {
            int widest = -1;
            float widestArea = -1.0f;
            for (uint32_t c = 0; c < n; ++c) {
                const BinaryNode& cn = tree.nodes[child[c]];
                if (cn.count > 0) continue;
                const float a = HalfArea(cn.box);
                if (a > widestArea) {
                    widestArea = a;
                    widest = int(c);
                }
            }
            if (widest < 0) break;
            const uint32_t w = child[widest];
            uint32_t below = std::max(need[w + 1], need[tree.nodes[w].first]);
            for (uint32_t c = 0; c < n; ++c) {
                if (c != uint32_t(widest)) below = std::max(below, need[child[c]]);
            }
            if (n + below > budget) break;
            child[widest] = w + 1;
            child[n++] = tree.nodes[w].first;
        }
        return n;
    }

    uint32_t Ref(uint32_t b, uint32_t budget) {
        if (!asLeaf[b]) return Node(b, budget);
        if (prims[b] > RC_BVH8_MAX_LEAF)
            throw std::runtime_error("bvh: a leaf of " + std::to_string(prims[b]) +
                                     " primitives, more than the kernels take (" +
                                     std::to_string(RC_BVH8_MAX_LEAF) + ")");
        return RC_BVH8_LEAF | (prims[b] - 1) << RC_BVH8_COUNT_SHIFT | firstPrim[b];
    }

    // The wide node of inner binary node b, for a walk that may push `budget` more entries (at
    // least need[b]): the optimal collapse's children where its walks fit, else Expand's. The
    // node pushes at most nChildren - 1 and leaves the rest to its children, each of which gets
    // at least its need: with budget >= greedy[b] the unbounded expansion leaves each child its
    // own greedy; else budget >= height[b], which two children fit, and Expand takes a third and
    // more only while they fit.
    uint32_t Node(uint32_t b, uint32_t budget) {
        uint32_t child[8];
        const uint32_t n = optimalNeed[b] <= budget
                               ? Distribute(b, 8, child, 0)
                               : Expand(b, child, budget >= greedy[b] ? ~0u : budget);
        const uint32_t self = uint32_t(nodes.size());
        nodes.emplace_back();
        RcBvh8Node wide{};
        wide.nChildren = n;
        // Unused slots keep empty boxes; the kernels mask them by nChildren.
        for (uint32_t c = 0; c < 8; ++c)
            SetChildBox(wide, c, c < n ? tree.nodes[child[c]].box : Bounds3f{});
        for (uint32_t c = 0; c < n; ++c) wide.child[c] = Ref(child[c], budget - (n - 1));
        nodes[self] = wide;
        return self;
    }
};

}  // namespace

std::vector<RcBvh8Node> Collapse(const Bvh& tree, uint32_t stackEntries) {
    if (tree.primIndex.size() > size_t(RC_BVH8_FIRST_MASK) + 1)
        throw std::runtime_error("bvh: more primitives than the kernels' leaves can address (" +
                                 std::to_string(RC_BVH8_FIRST_MASK + 1) + ")");
    Collapser c(tree);
    c.nodes.reserve(tree.nodes.size() / 4 + 1);
    const BinaryNode& root = tree.nodes[0];
    if (root.count == 0 && !tree.primIndex.empty()) {
        if (c.need[0] > stackEntries)
            throw std::runtime_error("bvh: the tree needs a stack of " + std::to_string(c.need[0]) +
                                     " entries, more than " + std::to_string(stackEntries));
        c.Node(0, stackEntries);
        return std::move(c.nodes);
    }
    // A single leaf (or no primitive): a root of one child (or none).
    RcBvh8Node wide{};
    wide.nChildren = tree.primIndex.empty() ? 0 : 1;
    for (uint32_t k = 0; k < 8; ++k)
        SetChildBox(wide, k, k < wide.nChildren ? root.box : Bounds3f{});
    if (wide.nChildren > 0) wide.child[0] = c.Ref(0, stackEntries);
    c.nodes.push_back(wide);
    return std::move(c.nodes);
}

}  // namespace rayclass::bvh
