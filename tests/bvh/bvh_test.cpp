// The SAH builder: every primitive in exactly one leaf, every node's box contains its children's
// boxes and its primitives' boxes, and the flattened layout is what cl/bvh.cl walks.
#include "rayclass/bvh/bvh.h"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <random>

#include "rayclass/scene/loader.h"

namespace rayclass::bvh {
namespace {

bool Contains(const RcBvhNode& outer, const Bounds3f& b) {
    return outer.boxMin.x <= b.lo.x && outer.boxMin.y <= b.lo.y && outer.boxMin.z <= b.lo.z &&
           outer.boxMax.x >= b.hi.x && outer.boxMax.y >= b.hi.y && outer.boxMax.z >= b.hi.z;
}

Bounds3f BoxOf(const RcBvhNode& n) {
    Bounds3f b;
    b.lo = {n.boxMin.x, n.boxMin.y, n.boxMin.z};
    b.hi = {n.boxMax.x, n.boxMax.y, n.boxMax.z};
    return b;
}

// Walks the tree from the root; checks containment and counts each primitive's leaves.
void CheckTree(const Bvh& t, std::span<const Bounds3f> boxes, const BuildParams& params) {
    ASSERT_FALSE(t.nodes.empty());
    std::vector<int> seen(boxes.size(), 0);
    std::vector<uint8_t> visited(t.nodes.size(), 0);
    std::vector<uint32_t> stack{0};
    while (!stack.empty()) {
        const uint32_t i = stack.back();
        stack.pop_back();
        ASSERT_LT(i, t.nodes.size());
        ASSERT_FALSE(visited[i]) << "node " << i << " reached twice";
        visited[i] = 1;
        const RcBvhNode& n = t.nodes[i];
        if (n.count > 0) {
            ASSERT_LE(size_t(n.first) + n.count, t.primIndex.size());
            for (uint32_t k = 0; k < n.count; ++k) {
                const uint32_t prim = t.primIndex[n.first + k];
                ASSERT_LT(prim, boxes.size());
                ++seen[prim];
                EXPECT_TRUE(Contains(n, boxes[prim])) << "leaf " << i << " prim " << prim;
            }
            continue;
        }
        ASSERT_LT(n.axis, 3u);
        const uint32_t lo = i + 1, hi = n.first;
        ASSERT_GT(hi, lo);
        ASSERT_LT(hi, t.nodes.size());
        EXPECT_TRUE(Contains(n, BoxOf(t.nodes[lo]))) << "node " << i;
        EXPECT_TRUE(Contains(n, BoxOf(t.nodes[hi]))) << "node " << i;
        stack.push_back(lo);
        stack.push_back(hi);
    }
    for (size_t p = 0; p < boxes.size(); ++p) EXPECT_EQ(seen[p], 1) << "primitive " << p;
    for (size_t i = 0; i < visited.size(); ++i) EXPECT_TRUE(visited[i]) << "orphan node " << i;
    EXPECT_LE(t.maxDepth, kMaxDepth);
    (void)params;
}

// n boxes in [-100, 100]^3 with edges up to maxSize (flat: no extent along z, like axis-aligned
// triangles), seeded.
std::vector<Bounds3f> RandomBoxes(uint32_t seed, size_t n, float maxSize, bool flat) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(-100.0f, 100.0f), size(0.0f, maxSize);
    std::vector<Bounds3f> boxes(n);
    for (auto& b : boxes) {
        const glm::vec3 p(pos(rng), pos(rng), pos(rng));
        b.lo = p;
        const float sx = size(rng), sy = size(rng);
        b.hi = p + glm::vec3(sx, sy, flat ? 0.0f : size(rng));
    }
    return boxes;
}

TEST(BvhBuild, RandomBoxes) {
    const std::vector<Bounds3f> boxes = RandomBoxes(7, 5000, 3.0f, /*flat=*/true);
    const BuildParams params;
    const Bvh t = Build(boxes, 1e-4f, params);
    CheckTree(t, boxes, params);
    // SAH splits: far from one leaf per maxLeafSize primitives in a chain.
    EXPECT_LT(t.maxDepth, 40u);
    for (const auto& n : t.nodes) {
        if (n.count > 0) {
            EXPECT_LE(n.count, params.maxLeafSize);
        }
    }
}

TEST(BvhBuild, ThreadsBuildTheSameTreeNodeForNode) {
    // Large enough that subtrees of 32768 primitives or more go to other threads at two levels.
    const std::vector<Bounds3f> boxes = RandomBoxes(11, 200000, 2.0f, /*flat=*/false);
    BuildParams serial;
    serial.threads = 1;
    const Bvh one = Build(boxes, 1e-4f, serial);
    CheckTree(one, boxes, serial);
    for (uint32_t threads : {2u, 4u}) {
        BuildParams params;
        params.threads = threads;
        const Bvh t = Build(boxes, 1e-4f, params);
        ASSERT_EQ(t.nodes.size(), one.nodes.size()) << threads;
        EXPECT_EQ(std::memcmp(t.nodes.data(), one.nodes.data(), t.nodes.size() * sizeof(RcBvhNode)),
                  0)
            << threads << " threads";
        EXPECT_EQ(t.primIndex, one.primIndex) << threads;
        EXPECT_EQ(t.maxDepth, one.maxDepth) << threads;
    }
}

TEST(BvhBuild, CoincidentCentroidsAreSplitByCount) {
    std::vector<Bounds3f> boxes(100);
    for (auto& b : boxes) {
        b.lo = glm::vec3(-1.0f);
        b.hi = glm::vec3(1.0f);
    }
    const BuildParams params;
    const Bvh t = Build(boxes, 0.0f, params);
    CheckTree(t, boxes, params);
    for (const auto& n : t.nodes) {
        if (n.count > 0) {
            EXPECT_LE(n.count, params.maxLeafSize);
        }
    }
}

TEST(BvhBuild, SinglePrimitiveIsOneLeaf) {
    std::vector<Bounds3f> boxes(1);
    boxes[0].lo = glm::vec3(0.0f);
    boxes[0].hi = glm::vec3(1.0f);
    const Bvh t = Build(boxes, 0.0f);
    ASSERT_EQ(t.nodes.size(), 1u);
    EXPECT_EQ(t.nodes[0].count, 1u);
    CheckTree(t, boxes, {});
}

TEST(BvhBuild, SceneWithAllPrimitiveKinds) {
    const char* source = std::getenv("RAYCLASS_SOURCE_DIR");
    const auto dir = std::filesystem::path(source ? source : ".") / "scenes";
    for (const char* file : {"cornell.json", "tests/quadrics.json", "tests/spheres.json"}) {
        const scene::Scene scene = scene::LoadScene(dir / file);
        std::vector<Bounds3f> boxes(scene.PrimitiveCount());
        for (uint32_t id = 0; id < boxes.size(); ++id) boxes[id] = scene.PrimitiveBounds(id);
        const Bvh t = Build(scene);
        CheckTree(t, boxes, {});
    }
}

}  // namespace
}  // namespace rayclass::bvh
