// Quantised nodes: every child box of a quantised node, in the floats the kernels compute from
// its grid (rc_types.h, RcBvh8QNode), holds the child's box of the collapsed node, and is no more
// than a grid step or two larger where float resolution allows.
#include "rayclass/bvh/quantised_node.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <random>

#include "rayclass/bvh/bvh.h"
#include "rayclass/bvh/leaf_blocks.h"

namespace rayclass::bvh {
namespace {

// rc_types.h's definition of grid value q, in float.
float Grid(const RcBvh8QNode& n, int axis, uint8_t q) {
    return n.origin[axis] + float(q) * std::ldexp(1.0f, int(n.exponent[axis]) - 127);
}

float Step(const RcBvh8QNode& n, int axis) { return std::ldexp(1.0f, int(n.exponent[axis]) - 127); }

// Every used child's grid box holds its box; returns the largest overhang in grid steps.
double CheckHolds(const RcBvh8Node& wide, const RcBvh8QNode& q) {
    EXPECT_EQ(q.nChildren, wide.nChildren);
    const float* lo[3] = {wide.loX, wide.loY, wide.loZ};
    const float* hi[3] = {wide.hiX, wide.hiY, wide.hiZ};
    const uint8_t* qlo[3] = {q.loX, q.loY, q.loZ};
    const uint8_t* qhi[3] = {q.hiX, q.hiY, q.hiZ};
    double overhang = 0.0;
    for (uint32_t c = 0; c < wide.nChildren; ++c) {
        EXPECT_EQ(q.child[c], wide.child[c]);
        for (int a = 0; a < 3; ++a) {
            const float l = Grid(q, a, qlo[a][c]), h = Grid(q, a, qhi[a][c]);
            EXPECT_LE(l, lo[a][c]) << "child " << c << " axis " << a;
            EXPECT_GE(h, hi[a][c]) << "child " << c << " axis " << a;
            EXPECT_TRUE(l == 0.0f || std::abs(l) >= FLT_MIN) << "subnormal bound";
            EXPECT_TRUE(h == 0.0f || std::abs(h) >= FLT_MIN) << "subnormal bound";
            const double step = Step(q, a);
            overhang =
                std::max({overhang, (double(lo[a][c]) - l) / step, (double(h) - hi[a][c]) / step});
        }
    }
    return overhang;
}

RcBvh8Node RandomNode(std::mt19937& rng, float center, float extent, float childMin) {
    std::uniform_real_distribution<float> pos(center - extent, center + extent);
    std::uniform_real_distribution<float> size(childMin, extent);
    RcBvh8Node n{};
    n.nChildren = 1 + rng() % 8;
    float* lo[3] = {n.loX, n.loY, n.loZ};
    float* hi[3] = {n.hiX, n.hiY, n.hiZ};
    for (uint32_t c = 0; c < n.nChildren; ++c) {
        n.child[c] = rng();
        for (int a = 0; a < 3; ++a) {
            lo[a][c] = pos(rng);
            hi[a][c] = lo[a][c] + size(rng);
        }
    }
    return n;
}

TEST(QuantisedNode, ChildBoxesHoldTheirBoxesWithinAGridStep) {
    std::mt19937 rng(11);
    for (int i = 0; i < 2000; ++i) {
        const RcBvh8Node wide = RandomNode(rng, 0.0f, 10.0f, 0.1f);
        const RcBvh8QNode q = Quantise(wide);
        // Grid steps well above the coordinates' float resolution: at most one step outward
        // (plus rounding of the sum), and the step at most twice the finest that spans the box.
        EXPECT_LE(CheckHolds(wide, q), 1.01);
        for (int a = 0; a < 3; ++a) {
            const float* lo = a == 0 ? wide.loX : a == 1 ? wide.loY : wide.loZ;
            const float* hi = a == 0 ? wide.hiX : a == 1 ? wide.hiY : wide.hiZ;
            const float boxLo = *std::min_element(lo, lo + wide.nChildren);
            const float boxHi = *std::max_element(hi, hi + wide.nChildren);
            EXPECT_LE(Step(q, a), 2.0 * (double(boxHi) - boxLo) / 255.0 * 1.0001);
        }
    }
}

TEST(QuantisedNode, HoldsBoxesBelowFloatResolutionAndAtExtremes) {
    std::mt19937 rng(12);
    for (int i = 0; i < 500; ++i) {
        // Tiny boxes far from zero (grid step below the float spacing), boxes across zero with
        // subnormal bounds, and boxes at the scene's coordinate limit.
        const RcBvh8Node far = RandomNode(rng, 1e6f, 1e-3f, 0.0f);
        CheckHolds(far, Quantise(far));
        RcBvh8Node tiny = RandomNode(rng, 0.0f, 1e-38f, 0.0f);
        tiny.loX[0] = -1e-40f;
        tiny.hiY[0] = 1e-41f;
        CheckHolds(tiny, Quantise(tiny));
        const RcBvh8Node huge = RandomNode(rng, 0.0f, scene::kMaxCoordinate, 0.0f);
        CheckHolds(huge, Quantise(huge));
        const RcBvh8Node point = RandomNode(rng, 3.0f, 0.0f, 0.0f);  // zero extent
        CheckHolds(point, Quantise(point));
    }
}

TEST(QuantisedNode, BlockedTreeNodesHoldTheCollapsedBoxes) {
    std::mt19937 rng(13);
    std::uniform_real_distribution<float> pos(-50.0f, 50.0f);
    std::vector<Bounds3f> boxes(5000);
    for (Bounds3f& b : boxes) {
        b.lo = {pos(rng), pos(rng), pos(rng)};
        b.hi = b.lo + glm::vec3(0.5f);
    }
    const Bvh tree = Build(boxes, 1e-4f);
    const std::vector<RcBvh8Node> wide = Collapse(tree);
    const BlockedBvh blocked = BlockLeaves(wide, tree.primIndex, scene::Scene{});
    ASSERT_EQ(blocked.nodes.size(), wide.size());
    for (size_t i = 0; i < wide.size(); ++i) {
        RcBvh8Node renamed = wide[i];  // leaf references name blocks now
        for (uint32_t c = 0; c < 8; ++c) renamed.child[c] = blocked.nodes[i].child[c];
        EXPECT_LE(CheckHolds(renamed, blocked.nodes[i]), 1.01) << "node " << i;
    }
}

}  // namespace
}  // namespace rayclass::bvh
