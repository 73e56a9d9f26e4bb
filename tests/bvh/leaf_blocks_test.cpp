// The leaf blocks cl/bvh.cl tests leaves from: every leaf of the collapsed tree renamed to blocks
// that hold its primitives in primIndex order, triangles with their vertex and edges, every other
// lane empty.
#include "rayclass/bvh/leaf_blocks.h"

#include <gtest/gtest.h>

#include <random>

#include "rayclass/bvh/bvh.h"

namespace rayclass::bvh {
namespace {

// Random triangles with a sphere after every seventh, so that blocks mix primitive kinds.
scene::Scene MixedScene(uint32_t nTriangles) {
    scene::Scene s;
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> pos(-10.0f, 10.0f), off(-0.5f, 0.5f);
    for (uint32_t i = 0; i < nTriangles; ++i) {
        const glm::vec3 a(pos(rng), pos(rng), pos(rng));
        scene::Triangle t;
        t.p = {a, a + glm::vec3(off(rng), off(rng), off(rng)),
               a + glm::vec3(off(rng), off(rng), off(rng))};
        s.triangles.push_back(t);
        if (i % 7 == 0) s.spheres.push_back({glm::vec3(pos(rng), pos(rng), pos(rng)), 0.3f});
    }
    return s;
}

TEST(LeafBlocks, EveryLeafNamesBlocksHoldingItsPrimitivesInOrder) {
    const scene::Scene scene = MixedScene(3000);
    BuildParams params;
    params.maxLeafSize = 12;  // with dear node visits, leaves of two blocks as well as one
    params.traversalCost = 100.0f;
    const Bvh tree = Build(scene, params);
    const std::vector<RcBvh8Node> wide = Collapse(tree);
    const BlockedBvh blocked = BlockLeaves(wide, tree.primIndex, scene);
    ASSERT_EQ(blocked.nodes.size(), wide.size());
    std::vector<int> seen(scene.PrimitiveCount(), 0);
    size_t blocksNamed = 0;
    bool twoBlocks = false;
    for (size_t i = 0; i < wide.size(); ++i) {
        ASSERT_EQ(blocked.nodes[i].nChildren, wide[i].nChildren);
        for (uint32_t c = 0; c < wide[i].nChildren; ++c) {
            const uint32_t ref = wide[i].child[c], renamed = blocked.nodes[i].child[c];
            if (!(ref & RC_BVH8_LEAF)) {
                EXPECT_EQ(renamed, ref);
                continue;
            }
            ASSERT_EQ(renamed & ~RC_BVH8_FIRST_MASK, ref & ~RC_BVH8_FIRST_MASK);
            const uint32_t first = ref & RC_BVH8_FIRST_MASK;
            const uint32_t count = ((ref & ~RC_BVH8_LEAF) >> RC_BVH8_COUNT_SHIFT) + 1;
            const uint32_t block = renamed & RC_BVH8_FIRST_MASK;
            const uint32_t nBlocks = (count + 7) / 8;
            twoBlocks |= nBlocks == 2;
            blocksNamed += nBlocks;
            ASSERT_LE(size_t(block) + nBlocks, blocked.blocks.size());
            for (uint32_t k = 0; k < 8 * nBlocks; ++k) {
                const RcBvhLeafBlock8& b = blocked.blocks[block + k / 8];
                const uint32_t lane = k % 8;
                if (k >= count) {
                    EXPECT_EQ(b.prim[lane], RC_NO_HIT);
                    EXPECT_EQ(b.e1x[lane], 0.0f);
                    EXPECT_EQ(b.e2y[lane], 0.0f);
                    continue;
                }
                const uint32_t prim = tree.primIndex[first + k];
                ASSERT_EQ(b.prim[lane], prim);
                ++seen[prim];
                if (prim >= scene.triangles.size()) {
                    EXPECT_EQ(b.e1x[lane], 0.0f);
                    EXPECT_EQ(b.e1y[lane], 0.0f);
                    EXPECT_EQ(b.e2z[lane], 0.0f);
                    continue;
                }
                const auto& p = scene.triangles[prim].p;
                EXPECT_EQ(b.v0x[lane], p[0].x);
                EXPECT_EQ(b.v0y[lane], p[0].y);
                EXPECT_EQ(b.v0z[lane], p[0].z);
                EXPECT_EQ(b.e1x[lane], p[1].x - p[0].x);
                EXPECT_EQ(b.e1y[lane], p[1].y - p[0].y);
                EXPECT_EQ(b.e1z[lane], p[1].z - p[0].z);
                EXPECT_EQ(b.e2x[lane], p[2].x - p[0].x);
                EXPECT_EQ(b.e2y[lane], p[2].y - p[0].y);
                EXPECT_EQ(b.e2z[lane], p[2].z - p[0].z);
            }
        }
    }
    EXPECT_TRUE(twoBlocks);
    EXPECT_EQ(blocksNamed, blocked.blocks.size());  // no block unnamed, none named twice
    for (size_t id = 0; id < seen.size(); ++id) EXPECT_EQ(seen[id], 1) << id;
}

}  // namespace
}  // namespace rayclass::bvh
