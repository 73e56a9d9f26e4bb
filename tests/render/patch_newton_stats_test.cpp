// The Newton counters of --stats (render/newton_stats.h) on patches built so that each search's
// ending is known in exact arithmetic: z = f(u) a cubic in Bernstein form whose Newton steps land
// on dyadic parameters, so the float iteration follows them exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>

#include "clrt/device.h"
#include "rayclass/clrt/context.h"
#include "rayclass/geometry/patch_intersect.h"
#include "rayclass/render/device_scene.h"
#include "rayclass/render/launch.h"
#include "rayclass/render/newton_stats.h"
#include "rayclass/scene/patch.h"

namespace rayclass::render {
namespace {

using clrt::testing::TestContext;

// x = x[i], y = y0 + y[j], z = z[i] at control point (i, j): the surface is z(u) over x(u),
// extruded along y.
scene::Patch Extruded(const double (&x)[4], const double (&y)[4], const double (&z)[4], double y0) {
    scene::Patch p;
    for (int i = 0; i < 4; ++i) {
        for (int j = 0; j < 4; ++j) p.p[4 * i + j] = {x[i], y0 + y[j], z[i], 1.0};
    }
    return p;
}

RcRay Ray(glm::vec3 o, glm::vec3 d) { return {{o.x, o.y, o.z, 0.0f}, {d.x, d.y, d.z, INFINITY}}; }

TEST(PatchNewtonStats, CountsEndingsOfKnownSearches) {
    const double lin[4] = {0.0, 1.0 / 3, 2.0 / 3, 1.0}, step[4] = {0, 0, 1, 1}, flat[4] = {};
    // Along +x at y = y0 + 1/2, z = 0 the ray's F is (0, -f(u)) at v = 1/2, so Newton runs on f
    // alone: u = 1/2 -> 0 -> 1/2 ... with |f| = 3 at both (the cap), 1/2 -> 0 where |f| = 5 > 3
    // (divergence), 1/2 -> 5/2 (out of the window).
    const double cycle[4] = {3, 1, -13, 9}, grows[4] = {5, 1, -15, 13}, leaves[4] = {0, -4, -5, 3};
    scene::Scene s;
    s.patches = {Extruded(lin, lin, flat, 0), Extruded(step, step, cycle, 10),
                 Extruded(step, step, grows, 20), Extruded(step, step, leaves, 30)};
    scene::SplitPatches(s, {s.patchFlatness, 1});
    ASSERT_EQ(s.patchBoxes.size(), 4u);
    const std::vector<RcRay> rays = {
        Ray({0.25f, 0.75f, 1.0f}, {0, 0, -1}),  // the flat patch, affine F: one step, a hit
        Ray({-1.0f, 10.5f, 0.0f}, {1, 0, 0}),   // cap after 12 steps
        Ray({-1.0f, 20.5f, 0.0f}, {1, 0, 0}),   // |f| grows after one step
        Ray({-1.0f, 30.5f, 0.0f}, {1, 0, 0}),   // leaves after one step
        Ray({-1.0f, 40.5f, 0.0f}, {1, 0, 0}),   // enters no box: no test
    };
    RcRenderParams params{};
    params.nQuadrics = AnalyticRecords(s);
    const SceneBuffers buffers(TestContext(), s, params);
    const cl::Program program = BuildRenderProgram(TestContext());
    const NewtonCounts c = CountNewton(TestContext(), program, buffers, params.nQuadrics, rays);
    EXPECT_EQ(c.rays, 5u);
    EXPECT_EQ(c.tests, 4u);
    EXPECT_EQ(c.steps, 1u + 12u + 1u + 1u);
    EXPECT_EQ(c.culled, 0u);
    EXPECT_EQ(c.converged, 1u);
    EXPECT_EQ(c.hits, 1u);
    EXPECT_EQ(c.onCap, 1u);
    EXPECT_EQ(c.diverged, 1u);
    EXPECT_EQ(c.left, 1u);
    EXPECT_DOUBLE_EQ(c.ToStats().at("steps_per_test"), 15.0 / 4.0);
    // The three searches that did not converge restart from the quarters (each quarter's control
    // points straddle both planes of its ray), and the restarts hit where the reference does.
    EXPECT_EQ(c.restarted, 3u);
    uint64_t referenceHits = 0;
    for (size_t k = 1; k < 4; ++k) {
        const glm::dvec3 o(rays[k].origin.x, rays[k].origin.y, rays[k].origin.z);
        const glm::dvec3 d(rays[k].direction.x, rays[k].direction.y, rays[k].direction.z);
        double t, u, v;
        referenceHits +=
            geometry::IntersectPatchReference(o, d, 0.0, INFINITY, s.patchBoxes[k], t, u, v);
    }
    EXPECT_EQ(referenceHits, 3u);
    EXPECT_EQ(c.restartHits, referenceHits);
}

}  // namespace
}  // namespace rayclass::render
