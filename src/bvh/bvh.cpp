#include "rayclass/bvh/bvh.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace rayclass::bvh {

namespace {

float HalfArea(const Bounds3f& b) {
    if (b.Empty()) return 0.0f;
    const glm::vec3 s = b.hi - b.lo;
    return s.x * s.y + s.y * s.z + s.z * s.x;
}

struct Builder {
    std::span<const Bounds3f> boxes;
    std::vector<glm::vec3> centroids;
    float pad;
    BuildParams params;
    Bvh out;

    float Outward(float x, float dir) const {
        return x + dir * (pad + std::abs(x) * (1.0f / 1048576.0f));
    }

    // Builds primIndex[begin, end) into node `self` (already allocated).
    void Node(uint32_t self, uint32_t begin, uint32_t end, uint32_t depth) {
        if (depth > kMaxDepth) throw std::runtime_error("bvh: tree deeper than the kernels' stack");
        out.maxDepth = std::max(out.maxDepth, depth);
        Bounds3f box, cbox;
        for (uint32_t i = begin; i < end; ++i) {
            box.Grow(boxes[out.primIndex[i]]);
            cbox.Grow(centroids[out.primIndex[i]]);
        }
        RcBvhNode& node = out.nodes[self];
        node.boxMin = {Outward(box.lo.x, -1), Outward(box.lo.y, -1), Outward(box.lo.z, -1), 0};
        node.boxMax = {Outward(box.hi.x, 1), Outward(box.hi.y, 1), Outward(box.hi.z, 1), 0};
        const uint32_t n = end - begin;
        auto makeLeaf = [&] {
            RcBvhNode& leaf = out.nodes[self];
            leaf.first = begin;
            leaf.count = n;
            leaf.axis = 0;
        };
        if (n <= 1) return makeLeaf();

        // Binned SAH over the centroid box: the cheapest split plane of all axes.
        const uint32_t nb = std::max(2u, params.bins);
        float bestCost = std::numeric_limits<float>::infinity();
        int bestAxis = -1;
        uint32_t bestSplit = 0;
        std::vector<Bounds3f> binBox(nb);
        std::vector<uint32_t> binCount(nb);
        std::vector<float> rightArea(nb);
        std::vector<uint32_t> rightCount(nb);
        auto binOf = [&](int axis, uint32_t prim) {
            const float lo = cbox.lo[axis], ext = cbox.hi[axis] - lo;
            const auto b = int32_t(float(nb) * ((centroids[prim][axis] - lo) / ext));
            return uint32_t(std::clamp<int32_t>(b, 0, int32_t(nb) - 1));
        };
        for (int axis = 0; axis < 3; ++axis) {
            if (!(cbox.hi[axis] > cbox.lo[axis])) continue;
            std::fill(binBox.begin(), binBox.end(), Bounds3f{});
            std::fill(binCount.begin(), binCount.end(), 0u);
            for (uint32_t i = begin; i < end; ++i) {
                const uint32_t prim = out.primIndex[i];
                const uint32_t b = binOf(axis, prim);
                binBox[b].Grow(boxes[prim]);
                ++binCount[b];
            }
            Bounds3f acc;
            uint32_t cnt = 0;
            for (uint32_t b = nb - 1; b > 0; --b) {
                acc.Grow(binBox[b]);
                cnt += binCount[b];
                rightArea[b] = HalfArea(acc);
                rightCount[b] = cnt;
            }
            acc = Bounds3f{};
            cnt = 0;
            for (uint32_t b = 1; b < nb; ++b) {  // split before bin b
                acc.Grow(binBox[b - 1]);
                cnt += binCount[b - 1];
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
            auto* first = out.primIndex.data() + begin;
            auto* last = out.primIndex.data() + end;
            auto* m = std::partition(first, last, [&](uint32_t prim) {
                return binOf(bestAxis, prim) < bestSplit;
            });
            mid = uint32_t(m - out.primIndex.data());
            if (mid == begin || mid == end) mid = begin + n / 2;
        }
        const uint32_t left = uint32_t(out.nodes.size());
        out.nodes.emplace_back();
        Node(left, begin, mid, depth + 1);
        const uint32_t right = uint32_t(out.nodes.size());
        out.nodes.emplace_back();
        Node(right, mid, end, depth + 1);
        RcBvhNode& node2 = out.nodes[self];
        node2.first = right;
        node2.count = 0;
        node2.axis = uint32_t(bestAxis);
    }
};

}  // namespace

Bvh Build(std::span<const Bounds3f> boxes, float pad, const BuildParams& params) {
    Builder b{boxes, {}, pad, params, {}};
    b.centroids.resize(boxes.size());
    for (size_t i = 0; i < boxes.size(); ++i) b.centroids[i] = boxes[i].Center();
    b.out.primIndex.resize(boxes.size());
    for (uint32_t i = 0; i < boxes.size(); ++i) b.out.primIndex[i] = i;
    b.out.nodes.reserve(std::max<size_t>(1, 2 * boxes.size()));
    b.out.nodes.emplace_back();
    if (boxes.empty()) {
        // No primitives: one node the kernels never look at (they skip traversal when the scene
        // has no primitive).
        b.out.nodes[0].first = 0;
        b.out.nodes[0].count = 0;
        return std::move(b.out);
    }
    b.Node(0, 0, uint32_t(boxes.size()), 0);
    return std::move(b.out);
}

Bvh Build(const scene::Scene& scene, const BuildParams& params) {
    std::vector<Bounds3f> boxes(scene.PrimitiveCount());
    for (uint32_t id = 0; id < boxes.size(); ++id) boxes[id] = scene.PrimitiveBounds(id);
    const Bounds3f sceneBox = scene.Bounds();
    const float pad = sceneBox.Empty() ? 0.0f : 1e-6f * sceneBox.Diagonal();
    return Build(boxes, pad, params);
}

}  // namespace rayclass::bvh
