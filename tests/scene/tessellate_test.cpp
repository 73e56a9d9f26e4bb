// The tessellator against the analytic sphere: the NURBS sphere's triangles have their vertices
// on the unit sphere and their normals radial, and they close the sphere (their areas sum to
// nearly 4 pi, less than it as chords do).
#include "rayclass/scene/tessellate.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "rayclass/scene/loader.h"

namespace rayclass::scene {
namespace {

std::filesystem::path ScenesDir() {
    const char* source = std::getenv("RAYCLASS_SOURCE_DIR");
    return std::filesystem::path(source ? source : ".") / "scenes";
}

TEST(Tessellate, NurbsSphereTrianglesLieOnTheSphere) {
    const Scene s = LoadScene(ScenesDir() / "tests/nurbs_sphere.json");
    ASSERT_FALSE(s.patches.empty());
    for (uint32_t n : {1u, 4u, 16u}) {
        double area = 0;
        size_t count = 0;
        for (const Patch& patch : s.patches) {
            for (const Triangle& t : TessellatePatch(patch, n)) {
                ++count;
                area += 0.5 * glm::length(glm::cross(glm::dvec3(t.p[1] - t.p[0]),
                                                     glm::dvec3(t.p[2] - t.p[0])));
                ASSERT_TRUE(t.hasNormals);
                for (int k = 0; k < 3; ++k) {
                    EXPECT_NEAR(glm::length(t.p[k]), 1.0f, 1e-6f) << n;
                    EXPECT_GT(glm::dot(t.n[k], glm::normalize(t.p[k])), 0.99999f) << n;
                }
            }
        }
        // Two triangles a quad, less those collapsed at the poles (one per quad touching one).
        EXPECT_LE(count, 2 * n * n * s.patches.size());
        EXPECT_GE(count, (2 * n * n - n) * s.patches.size());
        EXPECT_LT(area, 4 * M_PI);
        EXPECT_GT(area, 4 * M_PI * (n == 1 ? 0.5 : n == 4 ? 0.95 : 0.997)) << n;
    }
}

}  // namespace
}  // namespace rayclass::scene
