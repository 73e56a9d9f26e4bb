// The leaf runs cl/bvh.cl tests leaves from: every leaf of the collapsed tree renamed to an
// aligned run of words sized to its primitives, holding them in primIndex order, triangles with
// their vertex and edges, other primitives with zero edges; runs never overlap, and zero words
// follow the last.
#include "rayclass/bvh/leaf_blocks.h"

#include <gtest/gtest.h>

#include <bit>
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

TEST(LeafBlocks, EveryLeafNamesARunHoldingItsPrimitivesInOrder) {
    const scene::Scene scene = MixedScene(3000);
    BuildParams params;
    params.maxLeafSize = 12;  // with dear node visits, leaves of more than eight as well
    params.traversalCost = 100.0f;
    const Bvh tree = Build(scene, params);
    const std::vector<RcBvh8Node> wide = Collapse(tree);
    const BlockedBvh blocked = BlockLeaves(wide, tree.primIndex, scene);
    ASSERT_EQ(blocked.nodes.size(), wide.size());
    ASSERT_GE(blocked.leaves.size(), size_t(RC_BVH_LEAF_TAIL));
    const size_t runWords = blocked.leaves.size() - RC_BVH_LEAF_TAIL;
    std::vector<int> seen(scene.PrimitiveCount(), 0), owner(runWords, 0);
    bool longLeaf = false;
    size_t sized = 0;  // the runs' words, each rounded up to the alignment
    const auto word = [&](uint32_t run, uint32_t count, uint32_t a, uint32_t k) {
        return blocked.leaves[size_t(run) * RC_BVH_LEAF_ALIGN + size_t(a) * count + k];
    };
    const auto real = [&](uint32_t run, uint32_t count, uint32_t a, uint32_t k) {
        return std::bit_cast<float>(word(run, count, a, k));
    };
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
            const uint32_t run = renamed & RC_BVH8_FIRST_MASK;
            longLeaf |= count > 8;
            sized += (RC_BVH_LEAF_ARRAYS * count + RC_BVH_LEAF_ALIGN - 1) / RC_BVH_LEAF_ALIGN *
                     RC_BVH_LEAF_ALIGN;
            const size_t begin = size_t(run) * RC_BVH_LEAF_ALIGN;
            ASSERT_LE(begin + RC_BVH_LEAF_ARRAYS * count, runWords);
            for (size_t w = begin; w < begin + RC_BVH_LEAF_ARRAYS * count; ++w) ++owner[w];
            for (uint32_t k = 0; k < count; ++k) {
                const uint32_t prim = tree.primIndex[first + k];
                ASSERT_EQ(word(run, count, RC_BVH_LEAF_ARRAYS - 1, k), prim);
                ++seen[prim];
                if (prim >= scene.triangles.size()) {
                    for (uint32_t a = 3; a < 9; ++a) EXPECT_EQ(real(run, count, a, k), 0.0f);
                    continue;
                }
                const auto& p = scene.triangles[prim].p;
                EXPECT_EQ(real(run, count, 0, k), p[0].x);
                EXPECT_EQ(real(run, count, 1, k), p[0].y);
                EXPECT_EQ(real(run, count, 2, k), p[0].z);
                EXPECT_EQ(real(run, count, 3, k), p[1].x - p[0].x);
                EXPECT_EQ(real(run, count, 4, k), p[1].y - p[0].y);
                EXPECT_EQ(real(run, count, 5, k), p[1].z - p[0].z);
                EXPECT_EQ(real(run, count, 6, k), p[2].x - p[0].x);
                EXPECT_EQ(real(run, count, 7, k), p[2].y - p[0].y);
                EXPECT_EQ(real(run, count, 8, k), p[2].z - p[0].z);
            }
        }
    }
    EXPECT_TRUE(longLeaf);
    // Runs never overlap, and only the alignment leaves words between them.
    for (size_t w = 0; w < runWords; ++w) EXPECT_LE(owner[w], 1) << w;
    EXPECT_EQ(sized, runWords);
    for (uint32_t w = 0; w < RC_BVH_LEAF_TAIL; ++w) EXPECT_EQ(blocked.leaves[runWords + w], 0u);
    for (size_t id = 0; id < seen.size(); ++id) EXPECT_EQ(seen[id], 1) << id;
}

}  // namespace
}  // namespace rayclass::bvh
