// The fragment-style kernels test spheres and quadrics 16 rays at a time (rc_packet_sphere,
// rc_packet_quadric in cl/classified.cl) with the scalar routines' operations: their answers
// must be brute force's bit for bit. The scene has overlapping spheres, ellipsoids clipped to
// their upper halves (the clip box decides which root counts), a plane and a cylinder written as
// quadrics (the linear case a = 0 for rays in the plane's or along the cylinder's axis), and
// rays from inside and outside the primitives, in random and axis-parallel directions.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "clrt/device.h"
#include "query_io.h"
#include "rayclass/clrt/context.h"
#include "rayclass/render/brute_query.h"
#include "rayclass/render/classified_query.h"
#include "rayclass/render/device_scene.h"

namespace rayclass::render {
namespace {

using clrt::testing::TestContext;

scene::Scene SpheresAndQuadrics() {
    std::mt19937 rng(41);
    std::uniform_real_distribution<float> pos(-1.0f, 1.0f), rad(0.1f, 0.4f);
    scene::Scene s;
    for (int i = 0; i < 40; ++i) {
        s.spheres.push_back({glm::vec3(pos(rng), pos(rng), pos(rng)), rad(rng)});
    }
    for (int i = 0; i < 30; ++i) {
        // (x - cx)^2 + (y - cy)^2 + 4 (z - cz)^2 = r^2, clipped to y >= cy.
        const glm::vec3 c(pos(rng), pos(rng), pos(rng));
        const float r = rad(rng);
        scene::Quadric q;
        q.c = {1, 1,        4,        0,        0,
               0, -2 * c.x, -2 * c.y, -8 * c.z, c.x * c.x + c.y * c.y + 4 * c.z * c.z - r * r};
        q.boxMin = c - glm::vec3(r, 0.0f, r);
        q.boxMax = c + glm::vec3(r);
        s.quadrics.push_back(q);
    }
    scene::Quadric plane;  // y = -0.9 over a square
    plane.c = {0, 0, 0, 0, 0, 0, 0, 1, 0, 0.9f};
    plane.boxMin = {-1.0f, -1.0f, -1.0f};
    plane.boxMax = {1.0f, -0.8f, 1.0f};
    s.quadrics.push_back(plane);
    scene::Quadric cylinder;  // x^2 + y^2 = 0.3^2 along z, |z| <= 0.8
    cylinder.c = {1, 1, 0, 0, 0, 0, 0, 0, 0, -0.09f};
    cylinder.boxMin = {-0.3f, -0.3f, -0.8f};
    cylinder.boxMax = {0.3f, 0.3f, 0.8f};
    s.quadrics.push_back(cylinder);
    return s;
}

std::vector<RcRay> Rays(float tmax) {
    std::mt19937 rng(42);
    std::uniform_real_distribution<float> pos(-1.5f, 1.5f), dir(-1.0f, 1.0f);
    std::vector<RcRay> rays;
    for (int i = 0; i < 6000; ++i) {
        glm::vec3 d(dir(rng), dir(rng), dir(rng));
        if (i % 5 == 1) d = glm::vec3(0.0f, 0.0f, d.z < 0.0f ? -1.0f : 1.0f);  // along the cylinder
        if (i % 5 == 2) d.y = 0.0f;                                            // in the plane's
        if (glm::length(d) < 0.1f) d = glm::vec3(1.0f, 0.0f, 0.0f);
        d = glm::normalize(d);
        glm::vec3 o(pos(rng), pos(rng), pos(rng));
        if (i % 5 == 2) o.y = -0.9f + 0.05f * dir(rng);
        rays.push_back({{o.x, o.y, o.z, 1e-4f}, {d.x, d.y, d.z, tmax}});
    }
    return rays;
}

struct Queries {
    scene::Scene scene = SpheresAndQuadrics();
    cl::Program program = BuildRenderProgram(TestContext());
    SceneBuffers buffers{TestContext(), scene, Params()};
    std::unique_ptr<RayQuery> fragment =
        MakeClassifiedQuery(TestContext(), program, buffers, scene,
                            classify::Params::ForScene(scene), KernelStyle::kFragment);
    std::unique_ptr<RayQuery> brute = MakeBruteForceQuery(TestContext(), program, buffers);

    RcRenderParams Params() const {
        RcRenderParams p{};
        p.nSpheres = uint32_t(scene.spheres.size());
        p.nQuadrics = uint32_t(scene.quadrics.size());
        return p;
    }
};

TEST(FragmentQuery, SpheresAndQuadricsHitWhatBruteForceHits) {
    Queries q;
    const std::vector<RcRay> rays = Rays(INFINITY);
    const std::vector<RcHit> got = NearestHits(TestContext(), *q.fragment, rays);
    const std::vector<RcHit> brute = NearestHits(TestContext(), *q.brute, rays);
    const uint32_t nS = uint32_t(q.scene.spheres.size());
    uint32_t spheres = 0, quadrics = 0, mismatches = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        if (brute[i].prim != RC_NO_HIT) (brute[i].prim < nS ? spheres : quadrics) += 1;
        const bool same =
            got[i].prim == brute[i].prim && (brute[i].prim == RC_NO_HIT || got[i].t == brute[i].t);
        if (!same && ++mismatches <= 10) {
            ADD_FAILURE() << "ray " << i << ": fragment " << got[i].prim << " at " << got[i].t
                          << ", brute force " << brute[i].prim << " at " << brute[i].t;
        }
    }
    EXPECT_EQ(mismatches, 0u);
    EXPECT_GT(spheres, 1000u);
    EXPECT_GT(quadrics, 300u);
}

TEST(FragmentQuery, SpheresAndQuadricsBlockWhatBruteForceBlocks) {
    Queries q;
    for (const float tmax : {0.3f, 1.0f}) {
        const std::vector<RcRay> rays = Rays(tmax);
        const std::vector<uint8_t> got = BlockedAnswers(TestContext(), *q.fragment, rays);
        const std::vector<uint8_t> brute = BlockedAnswers(TestContext(), *q.brute, rays);
        uint32_t blocked = 0, mismatches = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
            blocked += brute[i];
            if (got[i] != brute[i] && ++mismatches <= 10) {
                ADD_FAILURE() << "ray " << i << " (tmax " << tmax << "): fragment " << int(got[i])
                              << ", brute force " << int(brute[i]);
            }
        }
        EXPECT_EQ(mismatches, 0u) << tmax;
        EXPECT_GT(blocked, rays.size() / 10) << tmax;
        EXPECT_LT(blocked, rays.size() * 9 / 10) << tmax;
    }
}

}  // namespace
}  // namespace rayclass::render
