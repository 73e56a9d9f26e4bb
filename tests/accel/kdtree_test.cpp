// The kd-tree's build on the host: every point of every primitive lies in a leaf that lists the
// primitive (checked by descending the tree from random points on triangles and on spheres'
// surfaces), its leaves hold far fewer references than brute force would test, and clipping
// keeps large triangles out of leaves they do not cross.
#include "rayclass/accel/kdtree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <random>

#include "accel_support.h"
#include "rayclass/scene/loader.h"

namespace rayclass::accel {
namespace {

// The leaf whose cell holds p (the lower side on a split plane).
const RcKdNode& LeafAt(const KdTree& tree, const glm::vec3& p) {
    uint32_t node = 0;
    while ((tree.nodes[node].word & 3u) != RC_KD_LEAF) {
        const uint32_t axis = tree.nodes[node].word & 3u;
        const float split = std::bit_cast<float>(tree.nodes[node].data);
        node = p[axis] <= split ? node + 1 : tree.nodes[node].word >> 2;
    }
    return tree.nodes[node];
}

bool Lists(const KdTree& tree, const RcKdNode& leaf, uint32_t prim) {
    const auto first = tree.primIndex.begin() + leaf.data;
    return std::binary_search(first, first + (leaf.word >> 2), prim);
}

TEST(KdTree, EveryPointOfEveryPrimitiveLiesInALeafListingIt) {
    const scene::Scene s = scene::LoadScene(SourceDir() / "scenes/tests/spheres.json");
    const scene::Scene bunny = scene::LoadScene(SourceDir() / "scenes/bench/bunny.obj");
    for (const scene::Scene* sc : {&s, &bunny}) {
        const KdTree tree = BuildKdTree(*sc);
        std::mt19937 rng(3);
        std::uniform_real_distribution<float> u(0.0f, 1.0f);
        uint32_t missing = 0;
        for (uint32_t id = 0; id < sc->triangles.size(); id += 7) {
            const auto& p = sc->triangles[id].p;
            float a = u(rng), b = u(rng);
            if (a + b > 1.0f) a = 1.0f - a, b = 1.0f - b;
            missing += !Lists(tree, LeafAt(tree, p[0] + a * (p[1] - p[0]) + b * (p[2] - p[0])), id);
        }
        for (uint32_t i = 0; i < sc->spheres.size(); ++i) {
            for (int k = 0; k < 200; ++k) {
                const glm::vec3 d =
                    glm::normalize(glm::vec3(u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f));
                const glm::vec3 p = sc->spheres[i].center + sc->spheres[i].radius * d;
                missing += !Lists(tree, LeafAt(tree, p), sc->SphereBase() + i);
            }
        }
        EXPECT_EQ(missing, 0u);
        EXPECT_GT(tree.leaves, 1u);
        EXPECT_LE(tree.maxDepth, kKdMaxDepth - 1);
    }
}

// One large triangle across the diagonal of a box of many small ones: clipped to the cells it
// crosses, it lies in far fewer leaves than its box overlaps.
TEST(KdTree, ClippedTrianglesStayOutOfLeavesTheyDoNotCross) {
    scene::Scene s;
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(0.0f, 10.0f);
    for (int i = 0; i < 4000; ++i) {
        const glm::vec3 c(u(rng), u(rng), u(rng));
        scene::Triangle t;
        t.p = {c, c + glm::vec3(0.05f, 0, 0), c + glm::vec3(0, 0.05f, 0)};
        s.triangles.push_back(t);
    }
    scene::Triangle big;
    big.p = {glm::vec3(0, 0, 0), glm::vec3(10, 10, 0), glm::vec3(10, 10, 10)};
    s.triangles.push_back(big);
    const KdTree tree = BuildKdTree(s);
    uint32_t leavesWithBig = 0, leavesInBox = 0;
    for (const RcKdNode& n : tree.nodes) {
        if ((n.word & 3u) != RC_KD_LEAF) continue;
        ++leavesInBox;
        leavesWithBig += Lists(tree, n, 4000);
    }
    EXPECT_GT(leavesWithBig, 0u);
    EXPECT_LT(leavesWithBig, leavesInBox / 4);
}

}  // namespace
}  // namespace rayclass::accel
