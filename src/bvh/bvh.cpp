#include "rayclass/bvh/bvh.h"

#include <algorithm>
#include <cmath>
#include <future>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>

namespace rayclass::bvh {

namespace {

float HalfArea(const Bounds3f& b) {
    if (b.Empty()) return 0.0f;
    const glm::vec3 s = b.hi - b.lo;
    return s.x * s.y + s.y * s.z + s.z * s.x;
}

// Subtrees of at least this many primitives may be built on another thread.
constexpr uint32_t kParallelPrims = 32768;

struct Builder {
    Builder(std::span<const Bounds3f> boxes_, std::span<const glm::vec3> centroids_, float pad_,
            const BuildParams& params_, std::span<uint32_t> primIndex_, uint32_t parallelDepth_)
        : boxes(boxes_),
          centroids(centroids_),
          pad(pad_),
          params(params_),
          primIndex(primIndex_),
          parallelDepth(parallelDepth_) {}

    std::span<const Bounds3f> boxes;
    std::span<const glm::vec3> centroids;
    float pad;
    BuildParams params;
    std::span<uint32_t> primIndex;  // shared: each builder partitions its own ranges of it
    uint32_t parallelDepth;         // nodes above this depth build their right child apart
    std::vector<BinaryNode> nodes;  // this builder's subtree, depth first, its root at 0
    uint32_t maxDepth = 0;
    // A node's SAH bins, reused by every node (a node is done with them before it recurses).
    std::vector<Bounds3f> binBox;
    std::vector<uint32_t> binCount, rightCount;
    std::vector<float> rightArea;

    float Outward(float x, float dir) const {
        return x + dir * (pad + std::abs(x) * (1.0f / 1048576.0f));
    }

    // Builds primIndex[begin, end) into node `self` (already allocated).
    void Node(uint32_t self, uint32_t begin, uint32_t end, uint32_t depth) {
        if (depth > kMaxDepth) throw std::runtime_error("bvh: tree deeper than the kernels' stack");
        maxDepth = std::max(maxDepth, depth);
        Bounds3f box, cbox;
        for (uint32_t i = begin; i < end; ++i) {
            box.Grow(boxes[primIndex[i]]);
            cbox.Grow(centroids[primIndex[i]]);
        }
        BinaryNode& node = nodes[self];
        node.box.lo = {Outward(box.lo.x, -1), Outward(box.lo.y, -1), Outward(box.lo.z, -1)};
        node.box.hi = {Outward(box.hi.x, 1), Outward(box.hi.y, 1), Outward(box.hi.z, 1)};
        const uint32_t n = end - begin;
        auto makeLeaf = [&] {
            BinaryNode& leaf = nodes[self];
            leaf.first = begin;
            leaf.count = n;
            leaf.axis = 0;
        };
        if (n <= 1) return makeLeaf();

        // Binned SAH over the centroid box: the cheapest split plane of all axes, every axis
        // binned in one pass over the primitives.
        const uint32_t nb = std::max(2u, params.bins);
        float bestCost = std::numeric_limits<float>::infinity();
        int bestAxis = -1;
        uint32_t bestSplit = 0;
        binBox.assign(3 * nb, Bounds3f{});
        binCount.assign(3 * nb, 0u);
        rightArea.resize(nb);
        rightCount.resize(nb);
        auto binOf = [&](int axis, uint32_t prim) {
            const float lo = cbox.lo[axis], ext = cbox.hi[axis] - lo;
            const auto b = int32_t(float(nb) * ((centroids[prim][axis] - lo) / ext));
            return uint32_t(std::clamp<int32_t>(b, 0, int32_t(nb) - 1));
        };
        bool split[3];
        for (int axis = 0; axis < 3; ++axis) split[axis] = cbox.hi[axis] > cbox.lo[axis];
        for (uint32_t i = begin; i < end; ++i) {
            const uint32_t prim = primIndex[i];
            for (int axis = 0; axis < 3; ++axis) {
                if (!split[axis]) continue;
                const uint32_t b = uint32_t(axis) * nb + binOf(axis, prim);
                binBox[b].Grow(boxes[prim]);
                ++binCount[b];
            }
        }
        for (int axis = 0; axis < 3; ++axis) {
            if (!split[axis]) continue;
            const Bounds3f* bins = binBox.data() + axis * nb;
            const uint32_t* counts = binCount.data() + axis * nb;
            Bounds3f acc;
            uint32_t cnt = 0;
            for (uint32_t b = nb - 1; b > 0; --b) {
                acc.Grow(bins[b]);
                cnt += counts[b];
                rightArea[b] = HalfArea(acc);
                rightCount[b] = cnt;
            }
            acc = Bounds3f{};
            cnt = 0;
            for (uint32_t b = 1; b < nb; ++b) {  // split before bin b
                acc.Grow(bins[b - 1]);
                cnt += counts[b - 1];
                if (cnt == 0 || rightCount[b] == 0) continue;
                const float cost = HalfArea(acc) * float(cnt) + rightArea[b] * float(rightCount[b]);
                if (cost < bestCost) {
                    bestCost = cost;
                    bestAxis = axis;
                    bestSplit = b;
                }
            }
        }
        const float leafCost = HalfArea(box) * float(n);
        const float splitCost = params.traversalCost * HalfArea(box) + bestCost;
        if (bestAxis < 0) {
            // Every centroid in one point: split in the middle of the list if it is too long.
            if (n <= params.maxLeafSize) return makeLeaf();
            bestAxis = 0;
        } else if (n <= params.maxLeafSize && leafCost <= splitCost) {
            return makeLeaf();
        }
        uint32_t mid;
        if (bestCost == std::numeric_limits<float>::infinity()) {
            mid = begin + n / 2;
        } else {
            auto* first = primIndex.data() + begin;
            auto* last = primIndex.data() + end;
            auto* m = std::partition(first, last, [&](uint32_t prim) {
                return binOf(bestAxis, prim) < bestSplit;
            });
            mid = uint32_t(m - primIndex.data());
            if (mid == begin || mid == end) mid = begin + n / 2;
        }
        const uint32_t left = uint32_t(nodes.size());
        nodes.emplace_back();
        uint32_t right;
        if (depth < parallelDepth && end - mid >= kParallelPrims) {
            // The right subtree on another thread, into its own nodes, appended after the left
            // one: the same tree, node for node, as built on one thread.
            Builder other(boxes, centroids, pad, params, primIndex, parallelDepth);
            other.nodes.reserve(2 * size_t(end - mid));
            other.nodes.emplace_back();
            auto done = std::async(std::launch::async, [&] { other.Node(0, mid, end, depth + 1); });
            Node(left, begin, mid, depth + 1);
            done.get();
            right = uint32_t(nodes.size());
            for (BinaryNode nd : other.nodes) {
                if (nd.count == 0) nd.first += right;  // an inner node's right child
                nodes.push_back(nd);
            }
            maxDepth = std::max(maxDepth, other.maxDepth);
        } else {
            Node(left, begin, mid, depth + 1);
            right = uint32_t(nodes.size());
            nodes.emplace_back();
            Node(right, mid, end, depth + 1);
        }
        BinaryNode& node2 = nodes[self];
        node2.first = right;
        node2.count = 0;
        node2.axis = uint32_t(bestAxis);
    }
};

void SetChildBox(RcBvh8Node& node, uint32_t c, const Bounds3f& box) {
    node.loX[c] = box.lo.x;
    node.loY[c] = box.lo.y;
    node.loZ[c] = box.lo.z;
    node.hiX[c] = box.hi.x;
    node.hiY[c] = box.hi.y;
    node.hiZ[c] = box.hi.z;
}

// Collapses binary subtrees into wide nodes, depth first (a node's index is below its children's).
struct Collapser {
    explicit Collapser(const Bvh& tree_)
        : tree(tree_), greedy(tree_.nodes.size(), 0), need(tree_.nodes.size(), 0) {
        // Children come after their parent: bottom up is back to front.
        std::vector<uint32_t> height(tree.nodes.size(), 0);
        for (size_t b = tree.nodes.size(); b-- > 0;) {
            const BinaryNode& n = tree.nodes[b];
            // A tree without primitives is a single node of count 0 that has no children.
            if (n.count > 0 || tree.primIndex.empty()) continue;
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
    std::vector<RcBvh8Node> nodes;

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
        const BinaryNode& n = tree.nodes[b];
        if (n.count == 0) return Node(b, budget);
        if (n.count > RC_BVH8_MAX_LEAF)
            throw std::runtime_error("bvh: a leaf of " + std::to_string(n.count) +
                                     " primitives, more than the kernels take (" +
                                     std::to_string(RC_BVH8_MAX_LEAF) + ")");
        return RC_BVH8_LEAF | (n.count - 1) << RC_BVH8_COUNT_SHIFT | n.first;
    }

    // The wide node of inner binary node b, for a walk that may push `budget` more entries (at
    // least need[b]). The node pushes at most nChildren - 1 and leaves the rest to its children,
    // each of which gets at least its need: with budget >= greedy[b] the unbounded expansion
    // leaves each child its own greedy; else budget >= height[b], which two children fit, and
    // Expand takes a third and more only while they fit.
    uint32_t Node(uint32_t b, uint32_t budget) {
        uint32_t child[8];
        const uint32_t n = Expand(b, child, budget >= greedy[b] ? ~0u : budget);
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

Bvh Build(std::span<const Bounds3f> boxes, float pad, const BuildParams& params) {
    Bvh out;
    std::vector<glm::vec3> centroids(boxes.size());
    for (size_t i = 0; i < boxes.size(); ++i) centroids[i] = boxes[i].Center();
    out.primIndex.resize(boxes.size());
    for (uint32_t i = 0; i < boxes.size(); ++i) out.primIndex[i] = i;
    if (boxes.empty()) {
        // No primitives: one node the kernels never look at (they skip traversal when the scene
        // has no primitive).
        out.nodes.emplace_back();
        out.nodes[0].first = 0;
        out.nodes[0].count = 0;
        return out;
    }
    const uint32_t threads =
        params.threads > 0 ? params.threads : std::max(1u, std::thread::hardware_concurrency());
    uint32_t parallelDepth = 0;  // 2^parallelDepth subtrees at most build at once
    while ((1u << parallelDepth) < threads) ++parallelDepth;
    Builder b(boxes, centroids, pad, params, out.primIndex, parallelDepth);
    b.nodes.reserve(2 * boxes.size());
    b.nodes.emplace_back();
    b.Node(0, 0, uint32_t(boxes.size()), 0);
    out.nodes = std::move(b.nodes);
    out.maxDepth = b.maxDepth;
    return out;
}

Bvh Build(const scene::Scene& scene, const BuildParams& params) {
    std::vector<Bounds3f> boxes(scene.PrimitiveCount());
    for (uint32_t id = 0; id < boxes.size(); ++id) boxes[id] = scene.PrimitiveBounds(id);
    const Bounds3f sceneBox = scene.Bounds();
    const float pad = sceneBox.Empty() ? 0.0f : 1e-6f * sceneBox.Diagonal();
    return Build(boxes, pad, params);
}

}  // namespace rayclass::bvh
