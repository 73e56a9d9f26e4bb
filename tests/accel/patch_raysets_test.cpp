// The benchmark's secondary rays from patch hits: their normal is the patch's at the hit's
// (u, v), checked on the NURBS sphere against the analytic sphere's (radial) normal.
#include <gtest/gtest.h>

#include "accel_support.h"
#include "rayclass/scene/loader.h"

namespace rayclass::accel {
namespace {

TEST(PatchRaySets, MirrorRaysLeaveByTheSurfaceNormal) {
    const Loaded l(scene::LoadScene(SourceDir() / "scenes/tests/nurbs_sphere.json"));
    const bench::RaySets sets = SampledRaySets(l, 48, 36);
    const std::vector<bench::BenchRay>& eye = sets.sets[0];
    const std::vector<bench::BenchRay>& mirror = sets.sets[2];
    ASSERT_GT(mirror.size(), 200u);
    size_t off = 0;
    for (size_t k = 0; k < mirror.size(); ++k) {
        const glm::vec3 d = eye[sets.pixels[2][k]].direction;
        // The origin lies just off the unit sphere centred at 0, along its normal.
        const glm::vec3 n = glm::normalize(mirror[k].origin);
        const glm::vec3 expected = d - 2.0f * glm::dot(d, n) * n;
        if (glm::length(mirror[k].direction - expected) > 2e-3f && ++off <= 5) {
            ADD_FAILURE() << "mirror ray " << k << " leaves off the reflection by "
                          << glm::length(mirror[k].direction - expected);
        }
    }
    EXPECT_EQ(off, 0u);
}

}  // namespace
}  // namespace rayclass::accel
