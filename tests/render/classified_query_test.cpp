// The classified query's hierarchies across generations: a generation's rays are classified as
// by a new query (BeginGeneration forgets the splits earlier generations made), while a later
// batch of the same generation still lands in the hierarchy its earlier batches built. The
// primitive tests a query reports tell the two apart: the same rays cost a different number of
// tests when they are routed through splits made for other rays.
#include "rayclass/render/classified_query.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "quad.h"
#include "query_io.h"
#include "rayclass/clrt/context.h"
#include "rayclass/render/auto_query.h"
#include "rayclass/render/device_scene.h"

namespace rayclass::render {
namespace {

clrt::Context& Ctx() {
    static clrt::Context ctx("cpu");
    return ctx;
}

// Two nested boxes, [-4, 4]^3 and [-1, 1]^3, their walls tiled with squares (16 x 16 and 8 x 8 a
// wall, 3,840 triangles), lit by one light between them.
void AddTiledBox(scene::Scene& s, float half, int tiles) {
    for (int axis = 0; axis < 3; ++axis) {
        for (float side : {-half, half}) {
            for (int i = 0; i < tiles; ++i) {
                for (int j = 0; j < tiles; ++j) {
                    auto at = [&](int a, int b) {
                        glm::vec3 p;
                        p[axis] = side;
                        p[(axis + 1) % 3] = half * (2.0f * float(a) / float(tiles) - 1.0f);
                        p[(axis + 2) % 3] = half * (2.0f * float(b) / float(tiles) - 1.0f);
                        return p;
                    };
                    AddQuad(s, at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                }
            }
        }
    }
}

scene::Scene NestedTiledBoxes() {
    scene::Scene s;
    AddTiledBox(s, 4.0f, 16);
    AddTiledBox(s, 1.0f, 8);
    scene::PointLight light;
    light.position = {-3.0f, -2.5f, -2.0f};
    s.lights.push_back(light);
    return s;
}

// Rays from a small cube of origins in random directions: two seeds give two sets of rays in
// the same region of ray space, so the second set runs through the first one's splits.
std::vector<RcRay> RaysNearOneCorner(uint32_t seed, uint32_t n) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(1.0f, 2.0f), dir(-1.0f, 1.0f);
    std::vector<RcRay> rays;
    while (rays.size() < n) {
        const glm::vec3 d(dir(rng), dir(rng), dir(rng));
        if (glm::length(d) < 0.1f || glm::length(d) > 1.0f) continue;
        const glm::vec3 u = glm::normalize(d);
        rays.push_back({{pos(rng), pos(rng), pos(rng), 1e-4f}, {u.x, u.y, u.z, INFINITY}});
    }
    return rays;
}

// Segments of length 3 along `rays`, as shadow rays. Toward a point light, shadow rays are
// classified from the light, where splits of their directions alone come out the same in a
// new hierarchy and in an old one; segments are classified from their origins, as nearest-hit
// rays are.
std::vector<RcRay> Segments(std::vector<RcRay> rays) {
    for (RcRay& r : rays) r.direction.w = 3.0f;
    return rays;
}

struct Fixture {
    scene::Scene scene = NestedTiledBoxes();
    cl::Program program = BuildRenderProgram(Ctx());
    SceneBuffers buffers{Ctx(), DeviceScene(scene), Params()};

    RcRenderParams Params() const {
        RcRenderParams p{};
        p.nTriangles = uint32_t(scene.triangles.size());
        p.nLights = uint32_t(scene.lights.size());
        p.maxDepth = 6;
        p.minWeight = 0.001f;
        return p;
    }

    std::unique_ptr<RayQuery> NewQuery() const {
        return MakeClassifiedQuery(Ctx(), program, buffers, scene,
                                   classify::Params::ForScene(scene), KernelStyle::kFragment);
    }

    // Nearest hits of a batch, shaded as the renderer shades them; returns the tests done.
    uint64_t Nearest(RayQuery& q, const std::vector<RcRay>& rays,
                     std::vector<RcHit>* hitsOut = nullptr) const {
        return NearestHits(Ctx(), q, rays, Params().nLights, hitsOut);
    }

    uint64_t Occluded(RayQuery& q, const std::vector<RcRay>& rays) const {
        uint64_t tests = 0;
        BlockedAnswers(Ctx(), q, rays, &tests);
        return tests;
    }
};

void BeginGeneration(RayQuery& q, uint32_t generation, const std::vector<RcRay>& rays) {
    KernelTimer timer;
    q.BeginGeneration(generation, UploadVector(Ctx(), rays), uint32_t(rays.size()), timer);
}

TEST(ClassifiedQuery, EachGenerationIsClassifiedAsByANewQuery) {
    const Fixture f;
    const std::vector<RcRay> first = RaysNearOneCorner(1, 20000),
                             second = RaysNearOneCorner(2, 20000);
    const std::vector<RcRay> firstShadow = Segments(first), secondShadow = Segments(second);

    std::vector<RcHit> freshHits, laterHits;
    const uint64_t fresh = f.Nearest(*f.NewQuery(), second, &freshHits);
    const uint64_t freshShadow = f.Occluded(*f.NewQuery(), secondShadow);

    // The second set as a later batch of the first set's generation: it runs through the first
    // set's splits and costs other tests (else this test could not tell the cases apart).
    const std::unique_ptr<RayQuery> shared = f.NewQuery();
    f.Nearest(*shared, first);
    f.Occluded(*shared, firstShadow);
    ASSERT_NE(f.Nearest(*shared, second), fresh);
    ASSERT_NE(f.Occluded(*shared, secondShadow), freshShadow);

    // The second set as the next generation.
    const std::unique_ptr<RayQuery> q = f.NewQuery();
    BeginGeneration(*q, 0, first);
    f.Nearest(*q, first);
    f.Occluded(*q, firstShadow);
    BeginGeneration(*q, 1, second);
    EXPECT_EQ(f.Nearest(*q, second, &laterHits), fresh);
    EXPECT_EQ(f.Occluded(*q, secondShadow), freshShadow);
    ASSERT_EQ(laterHits.size(), freshHits.size());
    for (size_t i = 0; i < freshHits.size(); ++i) {
        ASSERT_EQ(laterHits[i].prim, freshHits[i].prim) << "ray " << i;
        ASSERT_EQ(laterHits[i].t, freshHits[i].t) << "ray " << i;
    }

    // --accel auto passes the new generation on to its classification. Its sample of the other
    // query is timed; brute force, some 3,840 tests a ray, never wins it, so the classification
    // answers every batch here.
    const std::unique_ptr<RayQuery> a = MakeAutoQuery(
        Ctx(), f.NewQuery(), [&f] { return MakeBruteForceQuery(Ctx(), f.program, f.buffers); });
    BeginGeneration(*a, 0, first);
    f.Nearest(*a, first);
    f.Occluded(*a, firstShadow);
    BeginGeneration(*a, 1, second);
    EXPECT_EQ(f.Nearest(*a, second), fresh);
    EXPECT_EQ(f.Occluded(*a, secondShadow), freshShadow);
}

}  // namespace
}  // namespace rayclass::render
