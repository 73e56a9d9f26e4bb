// Patch boxes in every query path: brute force, the BVH and the classified styles must return the
// same hits bit for bit (the fragment style runs its own float16 Newton iteration), and brute
// force must agree with the double-precision reference (subdivision, not Newton from the box
// centre) on which rays hit the teapot and where.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <vector>

#include "clrt/device.h"
#include "query_io.h"
#include "rayclass/clrt/context.h"
#include "rayclass/geometry/intersect.h"
#include "rayclass/render/brute_query.h"
#include "rayclass/render/bvh_query.h"
#include "rayclass/render/classified_query.h"
#include "rayclass/render/device_scene.h"
#include "rayclass/scene/loader.h"
#include "scene/test_files.h"

namespace rayclass::render {
namespace {

using clrt::testing::TestContext;
using scene::testing::ScenesDir;

// The teapot alone (no floor, no sphere): every hit is a patch box's.
scene::Scene Teapot() {
    scene::Scene s = scene::LoadScene(ScenesDir() / "teapot.json");
    scene::Scene t;
    t.patches.assign(s.patches.begin(), s.patches.end() - 1);  // the last patch is the floor
    scene::SplitPatches(t, {t.patchFlatness, 0});
    return t;
}

// Rays from a shell around the teapot towards random points of its box (many hit, many graze
// its silhouettes), and rays leaving points on its surface (secondary rays).
std::vector<RcRay> Rays(const scene::Scene& s, float tmax, int n) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> uni(0.0f, 1.0f), dir(-1.0f, 1.0f);
    const Bounds3f box = s.Bounds();
    std::vector<RcRay> rays;
    for (int i = 0; i < n; ++i) {
        const glm::vec3 target = box.lo + glm::vec3(uni(rng), uni(rng), uni(rng)) * box.Size();
        glm::vec3 d(dir(rng), dir(rng), dir(rng));
        if (glm::length(d) < 0.1f) d = glm::vec3(0.0f, 0.0f, 1.0f);
        d = glm::normalize(d);
        const glm::vec3 o = target - 8.0f * d;
        rays.push_back({{o.x, o.y, o.z, 0.0f}, {d.x, d.y, d.z, tmax}});
    }
    return rays;
}

struct Queries {
    scene::Scene scene = Teapot();
    cl::Program program = BuildRenderProgram(TestContext());
    SceneBuffers buffers{TestContext(), scene, Params()};
    std::unique_ptr<RayQuery> brute = MakeBruteForceQuery(TestContext(), program, buffers);

    RcRenderParams Params() const {
        RcRenderParams p{};
        p.nQuadrics = AnalyticRecords(scene);
        return p;
    }
    std::vector<std::pair<const char*, std::unique_ptr<RayQuery>>> Others() {
        std::vector<std::pair<const char*, std::unique_ptr<RayQuery>>> out;
        out.emplace_back("bvh", MakeBvhQuery(TestContext(), program, buffers, scene));
        const auto params = classify::Params::ForScene(scene);
        out.emplace_back("scalar", MakeClassifiedQuery(TestContext(), program, buffers, scene,
                                                       params, KernelStyle::kScalar));
        out.emplace_back("vertex", MakeClassifiedQuery(TestContext(), program, buffers, scene,
                                                       params, KernelStyle::kVertex));
        out.emplace_back("fragment", MakeClassifiedQuery(TestContext(), program, buffers, scene,
                                                         params, KernelStyle::kFragment));
        return out;
    }
};

TEST(PatchQuery, EveryPathHitsWhatBruteForceHits) {
    Queries q;
    const std::vector<RcRay> rays = Rays(q.scene, INFINITY, 2000);
    const std::vector<RcHit> brute = NearestHits(TestContext(), *q.brute, rays);
    uint32_t hits = 0;
    for (const RcHit& h : brute) hits += h.prim != RC_NO_HIT;
    EXPECT_GT(hits, 500u);
    for (auto& [name, query] : q.Others()) {
        const std::vector<RcHit> got = NearestHits(TestContext(), *query, rays);
        uint32_t mismatches = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
            const bool same =
                got[i].prim == brute[i].prim &&
                (brute[i].prim == RC_NO_HIT ||
                 (got[i].t == brute[i].t && got[i].u == brute[i].u && got[i].v == brute[i].v));
            if (!same && ++mismatches <= 5) {
                ADD_FAILURE() << name << " ray " << i << ": " << got[i].prim << " at " << got[i].t
                              << ", brute force " << brute[i].prim << " at " << brute[i].t;
            }
        }
        EXPECT_EQ(mismatches, 0u) << name;
    }
}

TEST(PatchQuery, EveryPathBlocksWhatBruteForceBlocks) {
    Queries q;
    const std::vector<RcRay> rays = Rays(q.scene, 8.0f, 1500);
    const std::vector<uint8_t> brute = BlockedAnswers(TestContext(), *q.brute, rays);
    uint32_t blocked = 0;
    for (uint8_t b : brute) blocked += b;
    EXPECT_GT(blocked, 300u);
    for (auto& [name, query] : q.Others()) {
        EXPECT_EQ(BlockedAnswers(TestContext(), *query, rays), brute) << name;
    }
}

// The host's float Newton iteration (geometry/patch_intersect.h) is the kernels' twin.
TEST(PatchQuery, HostNewtonIsTheKernelsTwin) {
    Queries q;
    const std::vector<RcRay> rays = Rays(q.scene, INFINITY, 500);
    const std::vector<RcHit> brute = NearestHits(TestContext(), *q.brute, rays);
    for (size_t i = 0; i < rays.size(); ++i) {
        geometry::Ray<float> r;
        r.o = {rays[i].origin.x, rays[i].origin.y, rays[i].origin.z};
        r.d = {rays[i].direction.x, rays[i].direction.y, rays[i].direction.z};
        const auto host = geometry::IntersectBruteForce(q.scene, r);
        ASSERT_EQ(host.prim, brute[i].prim) << "ray " << i;
        if (host.Valid()) {
            ASSERT_EQ(host.t, brute[i].t) << "ray " << i;
        }
    }
}

// Against the reference: the rays that hit, and where. A hit the kernels miss is a hole (the
// box's Newton iteration diverged or stopped outside it while the surface is there); a hit at
// another distance is a nearer box missed the same way, or a box that the ray meets twice, where
// the iteration from the box's centre found the far root. Both shrink with flatter boxes and
// with the restarts from the box's quarters; the bounds are stated per split, and the default
// split's fail without the restarts.
struct ReferenceCounts {
    uint32_t hits = 0, holes = 0, extra = 0, far = 0;
};

ReferenceCounts CompareWithReference(float flatness) {
    Queries q;
    scene::SplitPatches(q.scene, {flatness, 0});
    const SceneBuffers buffers{TestContext(), q.scene, q.Params()};
    const std::unique_ptr<RayQuery> brute = MakeBruteForceQuery(TestContext(), q.program, buffers);
    const std::vector<RcRay> rays = Rays(q.scene, INFINITY, 1500);
    const std::vector<RcHit> got = NearestHits(TestContext(), *brute, rays);
    ReferenceCounts c;
    for (size_t i = 0; i < rays.size(); ++i) {
        geometry::Ray<double> r;
        r.o = {rays[i].origin.x, rays[i].origin.y, rays[i].origin.z};
        r.d = {rays[i].direction.x, rays[i].direction.y, rays[i].direction.z};
        const auto ref = geometry::IntersectBruteForce(q.scene, r);
        c.hits += ref.Valid();
        if (ref.Valid() && got[i].prim == RC_NO_HIT) ++c.holes;
        if (!ref.Valid() && got[i].prim != RC_NO_HIT) ++c.extra;
        if (ref.Valid() && got[i].prim != RC_NO_HIT && std::fabs(got[i].t - ref.t) > 1e-3 * ref.t) {
            ++c.far;
        }
    }
    return c;
}

TEST(PatchQuery, BruteForceAgreesWithTheReferenceAtTheDefaultSplit) {
    const ReferenceCounts c = CompareWithReference(scene::PatchSplit{}.flatness);
    EXPECT_GT(c.hits, 800u);
    EXPECT_LE(c.holes, c.hits / 500) << c.holes << " holes of " << c.hits;
    EXPECT_EQ(c.extra, 0u);
    EXPECT_LE(c.far, c.hits / 150) << c.far << " hits at another distance of " << c.hits;
}

TEST(PatchQuery, BruteForceAgreesWithTheReferenceAtAFineSplit) {
    const ReferenceCounts c = CompareWithReference(0.05f);
    EXPECT_LE(c.holes, c.hits / 500) << c.holes << " holes of " << c.hits;
    EXPECT_EQ(c.extra, 0u);
    EXPECT_LE(c.far, c.hits / 150) << c.far << " hits at another distance of " << c.hits;
}

}  // namespace
}  // namespace rayclass::render
