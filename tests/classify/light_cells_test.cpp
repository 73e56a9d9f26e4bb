// Shadow rays to point lights sorted into cells of their direction from the light
// (src/classify/light_cells.h): every ray lands once, inside its leaf's interval, and the
// queries answer exactly as brute force, for any grid and thread count; other generations take
// the general path.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "classify_support.h"
#include "rayclass/classify/hierarchy.h"
#include "support.h"

namespace rayclass::classify {
namespace {

const std::vector<glm::vec3> kLights = {
    {0.2f, 0.9f, 0.1f}, {-0.7f, 0.3f, 0.5f}, {0.5f, -0.6f, -0.4f}};

Params CellParams(const scene::Scene& s, int lightCells) {
    Params p = DeepParams(s);
    p.lightCells = lightCells;
    return p;
}

// The point a ray is classified at, as the general path maps it: from the light it ends at.
bool PointFromLight(const CommonEnds& ends, const Bounds3f& box, const Ray& ray, Ray5& out,
                    float& end) {
    const int match = ends.Match(ray);
    if (match < 0 || !ToRay5(ends.Oriented(ray, match), box, out)) return false;
    end = std::min(out.p[0] + out.reach, BoxInFace(out.face, box).hi[0]);
    return true;
}

TEST(LightCells, EveryRayLandsOnceInsideItsLeafOnEveryGrid) {
    const scene::Scene s = RandomScene(81, 500, 6, 3);
    const std::vector<Ray> full = ShadowSlots(s, kLights, 82, 900);
    std::vector<Ray> rays = full;
    // A slot with a position that is not finite misses, as the general path finds; so do the
    // empty slots, also a run of them that fills whole blocks of 16.
    rays[5].origin.x = std::numeric_limits<float>::quiet_NaN();
    for (size_t i = 100; i < 140; ++i) rays[i] = Ray{glm::vec3(0.0f), 0.0f, glm::vec3(0.0f), 0.0f};
    uint64_t live = 0;
    for (const Ray& r : rays) live += r.tMax > 0.0f && std::isfinite(r.origin.x) ? 1 : 0;
    const std::vector<bool> truth = BlockedBruteForce(s, rays);
    ASSERT_GT(std::count(truth.begin(), truth.end(), true), 300);
    ASSERT_GT(std::count(truth.begin(), truth.end(), false), 300);
    for (int cells : {4, 16, 64, 256, -1}) {
        SCOPED_TRACE(cells);
        Hierarchy h(s, CellParams(s, cells));
        // A generation before, whose scratch the next one must not take for its own.
        h.Classify(full, RayUse::kAnyHit);
        h.Reset();
        const LeafBatch batch = h.Classify(rays, RayUse::kAnyHit);
        // Automatic: 8 cells a side, the first grid with 8 rays a cell or fewer on all 18 faces
        // of the three lights.
        ASSERT_EQ(h.Counters().cellsPerSide, cells > 0 ? uint32_t(cells) : 8u);
        EXPECT_EQ(h.Counters().fromEnd, live);
        ExpectEveryRayOnce(batch, uint32_t(rays.size()));
        EXPECT_EQ(batch.missed.size(), rays.size() - live);
        EXPECT_GT(batch.leaves.size(), cells == 4 ? 30u : 100u);
        const CommonEnds ends = FindCommonEnds(rays, h.SceneBox(), 0.25f * h.GetParams().padding);
        ASSERT_EQ(ends.n, 3);
        for (const RcLeaf& leaf : batch.leaves) {
            const Box5& box = h.Nodes()[leaf.node].box;
            const int light = ends.Match(rays[batch.rayIndex[leaf.rayBegin]]);
            for (uint32_t j = 0; j < leaf.rayCount; ++j) {
                const uint32_t id = batch.rayIndex[leaf.rayBegin + j];
                Ray5 p;
                float end;
                ASSERT_TRUE(PointFromLight(ends, h.SceneBox(), rays[id], p, end)) << id;
                ASSERT_EQ(ends.Match(rays[id]), light) << "ray " << id;
                ASSERT_EQ(p.face, int(leaf.face)) << "ray " << id;
                ASSERT_TRUE(box.Contains(p.p)) << "ray " << id;
            }
        }
        EXPECT_EQ(Blocked(s, batch, rays), truth);
    }
}

// A cell with a long list is split further, its rays one by one: below the grid's depth, leaves
// hold the rays of part of a cell, inside their tight bounds, and the answers stay exact.
TEST(LightCells, CellsWithLongListsAreSplitBelowTheGrid) {
    const scene::Scene s = RandomScene(91, 3000, 0, 0);
    const std::vector<Ray> rays = ShadowSlots(s, {kLights[0]}, 92, 4000);
    Hierarchy h(s, CellParams(s, 4));
    const LeafBatch batch = h.Classify(rays, RayUse::kAnyHit);
    ASSERT_EQ(h.Counters().cellsPerSide, 4u);
    ExpectEveryRayOnce(batch, uint32_t(rays.size()));
    const CommonEnds ends = FindCommonEnds(rays, h.SceneBox(), 0.25f * h.GetParams().padding);
    int below = 0;
    for (const RcLeaf& leaf : batch.leaves) {
        const Node& node = h.Nodes()[leaf.node];
        below += node.depth > 4 ? 1 : 0;  // 4 cells a side: a single cell is at depth 4
        for (uint32_t j = 0; j < leaf.rayCount; ++j) {
            Ray5 p;
            float end;
            ASSERT_TRUE(PointFromLight(ends, h.SceneBox(), rays[batch.rayIndex[leaf.rayBegin + j]],
                                       p, end));
            ASSERT_TRUE(node.box.Contains(p.p));
        }
    }
    EXPECT_GT(below, 20);
    EXPECT_EQ(Blocked(s, batch, rays), BlockedBruteForce(s, rays));
}

TEST(LightCells, ResultDoesNotDependOnTheThreadCount) {
    const scene::Scene s = RandomScene(85, 600, 4, 2);
    const std::vector<Ray> rays = ShadowSlots(s, kLights, 86, 6000);
    LeafBatch first;
    for (uint32_t threads : {1u, 2u, 3u}) {
        Params p = CellParams(s, -1);
        p.threads = threads;
        p.taskRays = 500;  // many tasks, spawned from deep inside the roots
        Hierarchy h(s, p);
        const LeafBatch b = h.Classify(rays, RayUse::kAnyHit);
        ASSERT_GT(h.Counters().cellsPerSide, 0u);
        if (threads == 1) {
            first = b;
            continue;
        }
        ASSERT_EQ(b.leaves.size(), first.leaves.size()) << threads;
        for (size_t l = 0; l < b.leaves.size(); ++l) {
            const RcLeaf &x = b.leaves[l], &y = first.leaves[l];
            ASSERT_EQ(x.rayBegin, y.rayBegin);
            ASSERT_EQ(x.rayCount, y.rayCount);
            ASSERT_EQ(x.candCount, y.candCount);
            ASSERT_EQ(x.face, y.face);
            for (uint32_t c = 0; c < x.candCount; ++c) {
                ASSERT_EQ(b.candidates[x.candBegin + c].prim,
                          first.candidates[y.candBegin + c].prim);
            }
        }
        ASSERT_TRUE(std::equal(b.rayIndex.begin(), b.rayIndex.end(), first.rayIndex.begin(),
                               first.rayIndex.end()));
        EXPECT_EQ(b.missed, first.missed);
    }
}

// The cells bound a leaf's directions by whole cells, a little looser than its rays: the lists
// stay about as short as the general path's.
TEST(LightCells, TestsStayCloseToTheGeneralPath) {
    const scene::Scene s = RandomScene(87, 1000, 0, 0);
    const std::vector<Ray> rays = ShadowSlots(s, {kLights[0], kLights[2]}, 88, 8000);
    std::vector<Hit<float>> hits(rays.size());
    uint64_t tests[2];
    for (int cells : {0, -1}) {
        Hierarchy h(s, CellParams(s, cells));
        const LeafBatch b = h.Classify(rays, RayUse::kAnyHit);
        EXPECT_EQ(h.Counters().cellsPerSide > 0, cells != 0);
        tests[cells == 0 ? 0 : 1] = QueryHost(s, b, rays, hits, true);
    }
    EXPECT_LT(double(tests[1]), 1.3 * double(tests[0])) << tests[0] << " " << tests[1];
}

// The upper nodes' cone lists are kept from one generation to the next (light_cones.h): a later
// generation to the same light, whose common end lies a little elsewhere, tests fewer boxes than
// a new hierarchy does, and every generation answers as brute force, whichever lights come and
// go.
TEST(LightCells, LaterGenerationsReuseTheConeListsAndStayExact) {
    const scene::Scene s = RandomScene(93, 1000, 4, 2);
    const Params params = CellParams(s, -1);
    // Within reach of the first generation's cones.
    const glm::vec3 moved = kLights[0] + glm::vec3(0.1f * params.padding);
    Hierarchy h(s, params);
    for (uint32_t g = 0; g < 2; ++g) {
        const std::vector<Ray> rays = ShadowSlots(s, {g == 0 ? kLights[0] : moved}, 94 + g, 2000);
        h.Reset();
        const LeafBatch b = h.Classify(rays, RayUse::kAnyHit);
        ASSERT_GT(h.Counters().cellsPerSide, 0u);
        EXPECT_EQ(Blocked(s, b, rays), BlockedBruteForce(s, rays)) << g;
    }
    Hierarchy fresh(s, params);
    fresh.Classify(ShadowSlots(s, {moved}, 95, 2000), RayUse::kAnyHit);
    EXPECT_LT(h.Counters().boxTests, fresh.Counters().boxTests);
    std::mt19937 rng(96);
    std::uniform_real_distribution<float> pos(-0.8f, 0.8f);
    for (int g = 0; g < 4; ++g) {
        std::vector<glm::vec3> lights(3);
        for (glm::vec3& l : lights) l = {pos(rng), pos(rng), pos(rng)};
        if (g % 2 == 1) lights[1] = kLights[0];
        const std::vector<Ray> rays = ShadowSlots(s, lights, 97 + uint32_t(g), 400);
        h.Reset();
        const LeafBatch b = h.Classify(rays, RayUse::kAnyHit);
        ASSERT_GT(h.Counters().cellsPerSide, 0u);
        EXPECT_EQ(Blocked(s, b, rays), BlockedBruteForce(s, rays)) << g;
    }
}

TEST(LightCells, OtherGenerationsTakeTheGeneralPath) {
    const scene::Scene s = RandomScene(89, 400, 4, 2);
    std::vector<Ray> rays = ShadowSlots(s, {kLights[0], kLights[1]}, 90, 2000);
    // One segment that ends nowhere near a light, at a slot the common-end sample does not read:
    // the cells' first pass meets it and hands the generation to the general path.
    const size_t odd = 1 + rays.size() / 256;
    ASSERT_GT(rays[odd].tMax, 0.0f);
    rays[odd].tMax *= 0.5f;
    const std::vector<bool> truth = BlockedBruteForce(s, rays);
    Hierarchy h(s, CellParams(s, -1));
    const LeafBatch b = h.Classify(rays, RayUse::kAnyHit);
    EXPECT_EQ(h.Counters().cellsPerSide, 0u);
    ExpectEveryRayOnce(b, uint32_t(rays.size()));
    EXPECT_EQ(Blocked(s, b, rays), truth);

    // Switched off, and for nearest hits: the general path too.
    rays[odd].tMax *= 2.0f;
    Hierarchy off(s, CellParams(s, 0));
    off.Classify(rays, RayUse::kAnyHit);
    EXPECT_EQ(off.Counters().cellsPerSide, 0u);
    EXPECT_GT(off.Counters().fromEnd, 0u);
    Hierarchy nearest(s, CellParams(s, -1));
    nearest.Classify(rays, RayUse::kNearestHit);
    EXPECT_EQ(nearest.Counters().cellsPerSide, 0u);
    Hierarchy cells(s, CellParams(s, -1));
    EXPECT_EQ(Blocked(s, cells.Classify(rays, RayUse::kAnyHit), rays), BlockedBruteForce(s, rays));
    EXPECT_GT(cells.Counters().cellsPerSide, 0u);
}

}  // namespace
}  // namespace rayclass::classify
