// The classification's edge cases: every one must classify every ray exactly once and answer
// exactly what brute force answers.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "rayclass/classify/hierarchy.h"
#include "rayclass/classify/query.h"
#include "rayclass/geometry/offset.h"

namespace rayclass::classify {
namespace {

using geometry::Hit;

scene::Triangle Tri(glm::vec3 a, glm::vec3 b, glm::vec3 c) {
    scene::Triangle t;
    t.p = {a, b, c};
    return t;
}

// A grid of unit quads (two triangles each) in the planes x = 0, 1, 2 and y = -1.
scene::Scene Walls() {
    scene::Scene s;
    for (int x = 0; x < 3; ++x) {
        for (int j = -2; j < 2; ++j) {
            for (int k = -2; k < 2; ++k) {
                const glm::vec3 o{float(x), float(j), float(k)};
                s.triangles.push_back(Tri(o, o + glm::vec3(0, 1, 0), o + glm::vec3(0, 1, 1)));
                s.triangles.push_back(Tri(o, o + glm::vec3(0, 1, 1), o + glm::vec3(0, 0, 1)));
            }
        }
    }
    s.triangles.push_back(Tri({-1, -1, -2}, {3, -1, -2}, {3, -1, 2}));
    return s;
}

Params Deep(const scene::Scene& s) {
    Params p = Params::ForScene(s);
    p.minRays = 2;
    p.minCandidates = 1;
    p.splitGain = 1.0f;
    p.boxTestCost = 0.001f;
    p.rayMoveCost = 0.001f;
    return p;
}

// Classifies `rays` with deep and default parameters and checks coverage and hits.
void ExpectExact(const scene::Scene& s, const std::vector<Ray>& rays) {
    std::vector<Hit<float>> truth;
    for (const Ray& r : rays) truth.push_back(geometry::IntersectBruteForce(s, ToGeometryRay(r)));
    for (const Params& p : {Deep(s), Params::ForScene(s)}) {
        Hierarchy h(s, p);
        const LeafBatch batch = h.Classify(rays);
        std::vector<int> seen(rays.size(), 0);
        for (const RcLeaf& leaf : batch.leaves) {
            for (uint32_t j = 0; j < leaf.rayCount; ++j) ++seen[batch.rayIndex[leaf.rayBegin + j]];
        }
        for (uint32_t id : batch.missed) ++seen[id];
        std::vector<Hit<float>> hits(rays.size());
        QueryHost(s, batch, rays, hits);
        for (size_t i = 0; i < rays.size(); ++i) {
            ASSERT_EQ(seen[i], 1) << "ray " << i;
            EXPECT_EQ(hits[i].prim, truth[i].prim) << "ray " << i;
            if (truth[i].Valid()) {
                EXPECT_EQ(hits[i].t, truth[i].t) << "ray " << i;
            }
        }
    }
}

TEST(Ray5, FaceTiesGoToTheLowerAxis) {
    EXPECT_EQ(FaceOf({1, 1, 0}), 0);
    EXPECT_EQ(FaceOf({-1, 1, 0}), 1);
    EXPECT_EQ(FaceOf({0, -1, 1}), 3);
    EXPECT_EQ(FaceOf({0, 0, -1}), 5);
    Bounds3f box;
    box.Grow(glm::vec3(-1));
    box.Grow(glm::vec3(1));
    Ray5 r;
    ASSERT_TRUE(ToRay5({glm::vec3(0.5f, 0.25f, 0), 0, {-1, 1, 0}, 10}, box, r));
    EXPECT_EQ(r.face, 1);
    EXPECT_EQ(r.p[0], -0.5f);  // X = -p_x on the -x face
    EXPECT_EQ(r.p[3], 1.0f);   // u = d_y / |d_x|
    EXPECT_EQ(r.p[4], 0.0f);
}

TEST(Ray5, OriginsOutsideMoveToTheEntryPoint) {
    Bounds3f box;
    box.Grow(glm::vec3(-1));
    box.Grow(glm::vec3(1));
    Ray5 r;
    ASSERT_TRUE(ToRay5({glm::vec3(-5, 0.5f, 0), 0, {2, 0, 0}, 1e30f}, box, r));
    EXPECT_EQ(r.p[0], -1.0f);
    EXPECT_EQ(r.p[1], 0.5f);
    EXPECT_FLOAT_EQ(r.reach, 2.0f);
    EXPECT_FALSE(ToRay5({glm::vec3(-5, 3, 0), 0, {1, 0, 0}, 1e30f}, box, r));  // misses
    EXPECT_FALSE(ToRay5({glm::vec3(-5, 0, 0), 0, {1, 0, 0}, 2.0f}, box, r));   // ends before
    EXPECT_FALSE(ToRay5({glm::vec3(0), 0, {0, 0, 0}, 1.0f}, box, r));          // no direction
    EXPECT_FALSE(ToRay5({glm::vec3(0), 0, {NAN, 0, 1}, 1.0f}, box, r));
}

TEST(EdgeCases, RaysExactlyOnFaceBoundaries) {
    const scene::Scene s = Walls();
    std::vector<Ray> rays;
    for (int i = 0; i < 400; ++i) {
        const float a = float(i % 20) / 10.0f - 1.0f;
        const float b = float(i / 20) / 10.0f - 1.0f;
        const float sx = i % 2 ? -1.0f : 1.0f;
        rays.push_back({glm::vec3(-0.5f, a, b), 0, {1, sx, 0}, 1e30f});       // |dx| = |dy|
        rays.push_back({glm::vec3(1.5f, a, b), 0, {-1, 0, sx}, 1e30f});       // |dx| = |dz|
        rays.push_back({glm::vec3(0.5f, a, b), 0, {sx, sx, sx}, 1e30f});      // all three equal
    }
    ExpectExact(s, rays);
}

TEST(EdgeCases, AxisParallelRays) {
    const scene::Scene s = Walls();
    std::vector<Ray> rays;
    for (int i = 0; i < 300; ++i) {
        const float a = float(i % 17) / 8.0f - 1.0f;
        const float b = float(i / 17) / 8.0f - 1.0f;
        rays.push_back({glm::vec3(-0.5f, a, b), 0, {1, 0, 0}, 1e30f});
        rays.push_back({glm::vec3(2.5f, a, b), 0, {-1, 0, 0}, 1e30f});
        rays.push_back({glm::vec3(a, 1.5f, b), 0, {0, -1, 0}, 1e30f});
        rays.push_back({glm::vec3(a + 1.0f, b, 1.5f), 0, {0, 0, -1}, 1e30f});
        // Exactly along the quads' shared edges and on a wall's plane.
        rays.push_back({glm::vec3(-0.5f, std::round(a), std::round(b)), 0, {1, 0, 0}, 1e30f});
        rays.push_back({glm::vec3(1.0f, a, -3.0f), 0, {0, 0, 1}, 1e30f});
    }
    ExpectExact(s, rays);
}

TEST(EdgeCases, RaysStartingOnAPrimitive) {
    const scene::Scene s = Walls();
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> u(-1.9f, 1.9f), d(-1.0f, 1.0f);
    std::vector<Ray> rays;
    for (int i = 0; i < 1000; ++i) {
        const glm::vec3 p(float(i % 3), u(rng), u(rng));  // on a wall
        glm::vec3 dir(d(rng), d(rng), d(rng));
        if (glm::length(dir) < 1e-3f) dir = {1, 0, 0};
        rays.push_back({p, 0, dir, 1e30f});
        rays.push_back({p, 1e-4f, dir, 1e30f});
        rays.push_back({geometry::OffsetRayOrigin(p, glm::vec3(dir.x < 0 ? -1 : 1, 0, 0)), 0, dir,
                        1e30f});
    }
    ExpectExact(s, rays);
}

TEST(EdgeCases, OriginsOutsideTheBoxAndRaysThatMissIt) {
    const scene::Scene s = Walls();
    std::mt19937 rng(6);
    std::uniform_real_distribution<float> far(-20.0f, 20.0f);
    std::normal_distribution<float> n;
    std::vector<Ray> rays;
    for (int i = 0; i < 3000; ++i) {
        const glm::vec3 o(far(rng), far(rng), far(rng));
        // Half aim at the scene, half anywhere (most of those miss the box).
        const glm::vec3 target = i % 2 ? glm::vec3(far(rng), far(rng), far(rng)) * 0.1f
                                       : glm::vec3(n(rng), n(rng), n(rng)) * 100.0f;
        rays.push_back({o, 0, target - (i % 2 ? o : glm::vec3(0)), 1e30f});
    }
    rays.push_back({glm::vec3(-5, 0.5f, 0.5f), 0, {1, 0, 0}, 4.0f});  // ends before the walls
    ExpectExact(s, rays);
    Hierarchy h(s, Deep(s));
    EXPECT_GT(h.Classify(rays).missed.size(), 500u);
}

TEST(EdgeCases, ZeroAreaTriangles) {
    scene::Scene s = Walls();
    s.triangles.push_back(Tri({0.5f, 0, 0}, {0.5f, 0, 0}, {0.5f, 0, 0}));      // a point
    s.triangles.push_back(Tri({0.5f, -1, 0}, {0.5f, 1, 0}, {0.5f, 0, 0}));     // a segment
    s.triangles.push_back(Tri({1.5f, 0, -1}, {1.5f, 0, 1}, {1.5f, 0, 1}));     // repeated vertex
    std::vector<Ray> rays;
    for (int i = 0; i < 500; ++i) {
        const float a = float(i % 25) / 12.0f - 1.0f, b = float(i / 25) / 10.0f - 1.0f;
        rays.push_back({glm::vec3(0.25f, a, b), 0, {1, 0.01f * a, 0}, 1e30f});
        rays.push_back({glm::vec3(0.5f, a, b), 0, {0, 1, 0}, 1e30f});  // in the segment's line
    }
    ExpectExact(s, rays);
}

TEST(EdgeCases, ScenesOfOnePrimitive) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> pos(-2.0f, 2.0f);
    std::normal_distribution<float> n;
    std::vector<Ray> rays;
    for (int i = 0; i < 2000; ++i) {
        rays.push_back({glm::vec3(pos(rng), pos(rng), pos(rng)), 0,
                        glm::vec3(n(rng), n(rng), n(rng)), 1e30f});
        rays.push_back({glm::vec3(pos(rng), pos(rng), pos(rng)), 0,
                        -rays.back().origin + 0.1f * glm::vec3(n(rng), n(rng), n(rng)), 1e30f});
    }
    scene::Scene tri;
    tri.triangles.push_back(Tri({-1, -1, 0}, {1, -1, 0}, {0, 1, 0}));  // flat: zero-depth box
    ExpectExact(tri, rays);
    scene::Scene sphere;
    sphere.spheres.push_back({glm::vec3(0.1f, 0, 0), 0.5f});
    ExpectExact(sphere, rays);
    scene::Scene quadric;
    scene::Quadric q;
    q.c = {1, 1, 0, 0, 0, 0, 0, 0, 0, -0.25f};  // cylinder x^2 + y^2 = 0.25 along z, clipped
    q.boxMin = {-0.5f, -0.5f, -1};
    q.boxMax = {0.5f, 0.5f, 1};
    quadric.quadrics.push_back(q);
    ExpectExact(quadric, rays);
    ExpectExact(scene::Scene{}, rays);  // no primitive at all: every ray misses
}

TEST(EdgeCases, CoincidentPrimitivesBreakTiesByLowerId) {
    scene::Scene s = Walls();
    const uint32_t n = uint32_t(s.triangles.size());
    for (uint32_t i = 0; i < n; i += 3) s.triangles.push_back(s.triangles[i]);
    // Also a copy with rotated vertices (same plane, different arithmetic) and a sphere twin.
    s.triangles.push_back(Tri(s.triangles[0].p[1], s.triangles[0].p[2], s.triangles[0].p[0]));
    s.spheres.push_back({glm::vec3(1.5f, 0.0f, 0.0f), 0.3f});
    s.spheres.push_back({glm::vec3(1.5f, 0.0f, 0.0f), 0.3f});
    std::vector<Ray> rays;
    for (int i = 0; i < 800; ++i) {
        const float a = float(i % 40) / 20.0f - 1.0f, b = float(i / 40) / 10.0f - 1.0f;
        rays.push_back({glm::vec3(-0.5f, a, b), 0, {1, 0.05f, -0.03f}, 1e30f});
        rays.push_back({glm::vec3(1.2f, 0.3f * a, 0.3f * b), 0, {1, 0, 0}, 1e30f});
    }
    ExpectExact(s, rays);
    // The duplicates really tie: the copy's id never wins.
    Hierarchy h(s, Deep(s));
    const LeafBatch batch = h.Classify(rays);
    std::vector<Hit<float>> hits(rays.size());
    QueryHost(s, batch, rays, hits);
    for (const auto& hit : hits) {
        if (!hit.Valid()) continue;
        if (hit.prim < s.SphereBase()) {
            EXPECT_LT(hit.prim, n + 1) << hit.prim;
        } else {
            EXPECT_EQ(hit.prim, s.SphereBase());
        }
    }
}

// Rays with a finite tMax (shadow rays) end inside the scene: their leaves' lists stop at the
// largest end X, here before the walls at x = 1 and x = 2, and the hits stay exact. Rays in
// every direction, some starting outside the box, also check the per-face conversion.
TEST(EdgeCases, BoundedRaysListsStopAtTheirEnd) {
    const scene::Scene s = Walls();
    std::vector<Ray> rays;
    for (int j = 0; j < 40; ++j) {
        for (int k = 0; k < 40; ++k) {
            Ray r;
            r.origin = glm::vec3(-0.5f, -1.9f + 0.095f * float(j), -1.9f + 0.095f * float(k));
            r.direction = glm::normalize(glm::vec3(1.0f, 0.05f * float(j % 5), -0.03f * float(k % 7)));
            r.tMax = 0.9f;  // ends before x = 0.5
            rays.push_back(r);
        }
    }
    const size_t nBounded = rays.size();
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> pos(-3.0f, 3.0f), len(0.1f, 4.0f);
    std::normal_distribution<float> dir;
    for (int i = 0; i < 600; ++i) {
        Ray r;
        r.origin = glm::vec3(pos(rng), pos(rng), pos(rng));
        r.direction = glm::vec3(dir(rng), dir(rng), dir(rng));
        r.tMin = i % 4 == 0 ? 0.05f : 0.0f;
        r.tMax = len(rng);
        rays.push_back(r);
    }
    ExpectExact(s, rays);

    const std::vector<Ray> bounded(rays.begin(), rays.begin() + long(nBounded));
    for (const Params& p : {Deep(s), Params::ForScene(s)}) {
        Hierarchy h(s, p);
        const LeafBatch batch = h.Classify(bounded);
        ASSERT_TRUE(batch.missed.empty());
        for (const RcLeaf& leaf : batch.leaves) {
            ASSERT_EQ(leaf.face, 0u);
            for (uint32_t c = 0; c < leaf.candCount; ++c) {
                EXPECT_LT(batch.candidates[leaf.candBegin + c].nearX, 0.5f)
                    << "prim " << batch.candidates[leaf.candBegin + c].prim;
            }
        }
    }
}

}  // namespace
}  // namespace rayclass::classify
