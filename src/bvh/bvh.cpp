#include "rayclass/bvh/bvh.h"

#include <algorithm>
#include <cmath>
#include <future>
#include <limits>
#include <stdexcept>
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
    std::vector<RcBvhNode> nodes;   // this builder's subtree, depth first, its root at 0
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
        RcBvhNode& node = nodes[self];
        node.boxMin = {Outward(box.lo.x, -1), Outward(box.lo.y, -1), Outward(box.lo.z, -1), 0};
        node.boxMax = {Outward(box.hi.x, 1), Outward(box.hi.y, 1), Outward(box.hi.z, 1), 0};
        const uint32_t n = end - begin;
        auto makeLeaf = [&] {
            RcBvhNode& leaf = nodes[self];
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
            for (RcBvhNode nd : other.nodes) {
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
        RcBvhNode& node2 = nodes[self];
        node2.first = right;
        node2.count = 0;
        node2.axis = uint32_t(bestAxis);
    }
};

}  // namespace

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
