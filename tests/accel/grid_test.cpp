// The grid's build on the host: the separating-axis overlap test agrees with clipping the
// triangle to the box (two independent answers to the same question) on random triangles and
// boxes, every point of every triangle lies in a cell that lists it, and the density rule gives
// about `density` cells per primitive.
#include "rayclass/accel/grid.h"

#include <gtest/gtest.h>

#include <random>

#include "accel_support.h"
#include "rayclass/accel/triangle_box.h"
#include "rayclass/scene/loader.h"

namespace rayclass::accel {
namespace {

TEST(TriangleBox, SeparatingAxesAgreeWithClipping) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u(-2.0, 2.0);
    uint32_t overlaps = 0, disagreements = 0;
    for (int i = 0; i < 20000; ++i) {
        const Triangle3d t = {glm::dvec3(u(rng), u(rng), u(rng)),
                              glm::dvec3(u(rng), u(rng), u(rng)),
                              glm::dvec3(u(rng), u(rng), u(rng))};
        const glm::dvec3 c(u(rng) * 0.5, u(rng) * 0.5, u(rng) * 0.5);
        const glm::dvec3 h(0.1 + std::abs(u(rng)) * 0.2, 0.1 + std::abs(u(rng)) * 0.2,
                           0.1 + std::abs(u(rng)) * 0.2);
        const Bounds3d box{c - h, c + h};
        const bool sat = TriangleOverlapsBox(t, box);
        overlaps += sat;
        disagreements += sat != !ClipTriangle(t, box).Empty();
    }
    EXPECT_EQ(disagreements, 0u);
    EXPECT_GT(overlaps, 2000u);
    EXPECT_LT(overlaps, 18000u);
}

TEST(Grid, EveryPointOfEveryTriangleLiesInACellListingIt) {
    const scene::Scene bunny = scene::LoadScene(SourceDir() / "scenes/bench/bunny.obj");
    const Grid g = BuildGrid(bunny);
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    uint32_t missing = 0;
    for (uint32_t id = 0; id < bunny.triangles.size(); id += 5) {
        const auto& p = bunny.triangles[id].p;
        float a = u(rng), b = u(rng);
        if (a + b > 1.0f) a = 1.0f - a, b = 1.0f - b;
        const glm::vec3 x = p[0] + a * (p[1] - p[0]) + b * (p[2] - p[0]);
        const glm::uvec3 c = glm::min(glm::uvec3((x - g.box.lo) / g.cellSize), g.resolution - 1u);
        const uint32_t cell = c.x + g.resolution.x * (c.y + g.resolution.y * c.z);
        const auto first = g.primIndex.begin() + g.cellStart[cell];
        missing += !std::binary_search(first, g.primIndex.begin() + g.cellStart[cell + 1], id);
    }
    EXPECT_EQ(missing, 0u);
    const double cellsPerPrim = double(g.Cells()) / bunny.PrimitiveCount();
    EXPECT_GT(cellsPerPrim, 2.0);
    EXPECT_LT(cellsPerPrim, 8.0);
    // Conservative, not by boxes: the bunny's triangles fill few of the cells their boxes touch.
    EXPECT_GT(g.emptyCells, g.Cells() / 2);
}

TEST(Grid, MacroCellsFlagExactlyThoseHoldingAPrimitive) {
    const scene::Scene bunny = scene::LoadScene(SourceDir() / "scenes/bench/bunny.obj");
    const Grid g = BuildGrid(bunny);
    ASSERT_GT(g.macroSize, 1u);
    const glm::uvec3 m = g.macroResolution;
    ASSERT_EQ(g.macroOccupied.size(), size_t(m.x) * m.y * m.z);
    uint32_t wrong = 0, occupied = 0;
    for (uint32_t z = 0; z < m.z; ++z) {
        for (uint32_t y = 0; y < m.y; ++y) {
            for (uint32_t x = 0; x < m.x; ++x) {
                // Scans the macro cell's cells' primitive lists directly.
                uint32_t refs = 0;
                const glm::uvec3 lo = glm::uvec3(x, y, z) * g.macroSize;
                const glm::uvec3 hi = glm::min(lo + g.macroSize, g.resolution);
                for (uint32_t cz = lo.z; cz < hi.z; ++cz) {
                    for (uint32_t cy = lo.y; cy < hi.y; ++cy) {
                        for (uint32_t cx = lo.x; cx < hi.x; ++cx) {
                            const uint32_t c = cx + g.resolution.x * (cy + g.resolution.y * cz);
                            refs += g.cellStart[c + 1] - g.cellStart[c];
                        }
                    }
                }
                const bool flagged = g.macroOccupied[x + m.x * (y + m.y * z)] != 0;
                wrong += flagged != (refs > 0);
                occupied += flagged;
            }
        }
    }
    EXPECT_EQ(wrong, 0u);
    // The bunny leaves much of its box empty even at the macro cells' scale.
    EXPECT_GT(occupied, 0u);
    EXPECT_LT(occupied, g.macroOccupied.size());
}

}  // namespace
}  // namespace rayclass::accel
