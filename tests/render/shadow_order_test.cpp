// ShadowOrder: the order shadow rays go to the BVH in, checked against what the rays themselves
// say (their ends, their directions, whether their slot is empty) and against the order they
// came in.
#include "shadow_order.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/glm.hpp>
#include <numeric>
#include <random>
#include <vector>

#include "shadow_ray.h"

namespace rayclass::render {
namespace {

Bounds3f Box() {
    Bounds3f box;
    box.Grow(glm::vec3(-4.0f));
    box.Grow(glm::vec3(4.0f));
    return box;
}

// Shadow rays from random origins in the box toward one light, every seventh slot empty.
std::vector<RcRay> Scattered(size_t n, const glm::vec3& light, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(-4.0f, 4.0f);
    std::vector<RcRay> rays;
    for (size_t i = 0; i < n; ++i) {
        rays.push_back(ShadowRay({pos(rng), pos(rng), pos(rng)}, light));
        if (i % 7 == 3) rays.back().direction = {0.0f, 0.0f, 0.0f, 0.0f};
    }
    return rays;
}

// The mean angle between the directions of neighbours in `order` that are both live.
double MeanNeighbourAngle(const std::vector<RcRay>& rays, const std::vector<uint32_t>& order) {
    double sum = 0.0;
    size_t pairs = 0;
    for (size_t i = 1; i < order.size(); ++i) {
        const RcRay &a = rays[order[i - 1]], &b = rays[order[i]];
        if (a.direction.w == 0.0f || b.direction.w == 0.0f) continue;
        const double c = double(a.direction.x) * b.direction.x +
                         double(a.direction.y) * b.direction.y +
                         double(a.direction.z) * b.direction.z;
        sum += std::acos(std::clamp(c, -1.0, 1.0));
        ++pairs;
    }
    return sum / double(pairs);
}

TEST(ShadowOrder, IsAPermutationWithEmptySlotsLastInTheirOrder) {
    const std::vector<RcRay> rays = Scattered(5000, {0.5f, 3.0f, -1.0f}, 1);
    ShadowOrder order(Box());
    const std::vector<uint32_t> sorted = order.Sort(rays);
    ASSERT_EQ(sorted.size(), rays.size());
    std::vector<uint32_t> seen = sorted;
    std::sort(seen.begin(), seen.end());
    std::vector<uint32_t> all(rays.size());
    std::iota(all.begin(), all.end(), 0u);
    EXPECT_EQ(seen, all);
    std::vector<uint32_t> empty;
    for (uint32_t i = 0; i < rays.size(); ++i)
        if (rays[i].direction.w == 0.0f) empty.push_back(i);
    ASSERT_FALSE(empty.empty());
    const std::vector<uint32_t> tail(sorted.end() - std::ptrdiff_t(empty.size()), sorted.end());
    EXPECT_EQ(tail, empty);
}

TEST(ShadowOrder, EqualRaysKeepTheirOrder) {
    std::vector<RcRay> rays(100, ShadowRay({1.0f, 0.0f, 0.0f}, {0.0f, 2.0f, 0.0f}));
    ShadowOrder order(Box());
    const std::vector<uint32_t> sorted = order.Sort(rays);
    for (uint32_t i = 0; i < rays.size(); ++i) EXPECT_EQ(sorted[i], i);
}

TEST(ShadowOrder, NeighboursLeaveTheLightInNearlyOneDirection) {
    const std::vector<RcRay> rays = Scattered(20000, {0.0f, 3.5f, 0.0f}, 2);
    ShadowOrder order(Box());
    const std::vector<uint32_t> sorted = order.Sort(rays);
    std::vector<uint32_t> given(rays.size());
    std::iota(given.begin(), given.end(), 0u);
    // 64 x 64 cells over the octahedron: a cell spans a few degrees.
    EXPECT_LT(MeanNeighbourAngle(rays, sorted), 0.05);
    EXPECT_GT(MeanNeighbourAngle(rays, given), 0.5);
}

TEST(ShadowOrder, RaysTowardTwoLightsFollowTheirLight) {
    // Slots of one origin side by side, one per light, as the renderer lays them out.
    const glm::vec3 lights[2] = {{-3.0f, 3.5f, -3.0f}, {3.0f, 3.5f, 3.0f}};
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> pos(-4.0f, 4.0f);
    std::vector<RcRay> rays;
    for (int i = 0; i < 4000; ++i) {
        const glm::vec3 o(pos(rng), pos(rng), pos(rng));
        for (const glm::vec3& light : lights) rays.push_back(ShadowRay(o, light));
    }
    ShadowOrder order(Box());
    const std::vector<uint32_t> sorted = order.Sort(rays);
    size_t changes = 0;
    for (size_t i = 1; i < sorted.size(); ++i) changes += sorted[i] % 2 != sorted[i - 1] % 2;
    EXPECT_LT(changes, sorted.size() / 20);
}

}  // namespace
}  // namespace rayclass::render
