// Where Newton iteration on patches can fail, measured through the brute-force kernel against
// closed forms: a rational NURBS sphere (exact, its conics made by weights) against the analytic
// sphere, at scales 1e-4, 1 and 1e4 (hit distance, normal, which rays hit, grazing rays included);
// rays leaving the sphere's surface from the renderer's offset origins (self-intersection); and
// a NURBS torus, whose hits must lie on the analytic torus with its normal and whose misses must
// be the reference's.
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
#include "rayclass/geometry/offset.h"
#include "rayclass/render/brute_query.h"
#include "rayclass/render/device_scene.h"
#include "rayclass/scene/loader.h"

namespace rayclass::render {
namespace {

using clrt::testing::TestContext;

scene::Scene TestScene(const char* file, float scale) {
    const char* source = std::getenv("RAYCLASS_SOURCE_DIR");
    scene::Scene s =
        scene::LoadScene(std::filesystem::path(source ? source : ".") / "scenes/tests" / file);
    for (scene::Patch& p : s.patches) {
        for (glm::dvec4& h : p.p) h = glm::dvec4(glm::dvec3(h) * double(scale), h.w);
    }
    scene::SplitPatches(s, {s.patchFlatness, 0});
    return s;
}

struct Brute {
    scene::Scene scene;
    cl::Program program = BuildRenderProgram(TestContext());
    SceneBuffers buffers{TestContext(), scene, Params()};
    std::unique_ptr<RayQuery> query = MakeBruteForceQuery(TestContext(), program, buffers);

    RcRenderParams Params() const {
        RcRenderParams p{};
        p.nQuadrics = AnalyticRecords(scene);
        return p;
    }
};

// Rays from a shell of radius 4 r towards points of the disc of radius 1.02 r facing them: some
// miss, many graze the silhouette.
std::vector<RcRay> RaysAtSphere(float r, int n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> uni(-1.0f, 1.0f);
    std::vector<RcRay> rays;
    while (int(rays.size()) < n) {
        glm::vec3 d(uni(rng), uni(rng), uni(rng));
        if (glm::length(d) < 0.1f || glm::length(d) > 1.0f) continue;
        d = glm::normalize(d);
        const glm::vec3 a = glm::normalize(
            glm::cross(d, std::fabs(d.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0)));
        const glm::vec3 b = glm::cross(d, a);
        const float x = uni(rng), y = uni(rng);
        const glm::vec3 o = 1.02f * r * (x * a + y * b) - 4.0f * r * d;
        rays.push_back({{o.x, o.y, o.z, 0.0f}, {d.x, d.y, d.z, INFINITY}});
    }
    return rays;
}

// The analytic sphere of radius r at the origin, in double.
double SphereT(const RcRay& ray, double r) {
    const glm::dvec3 o(ray.origin.x, ray.origin.y, ray.origin.z);
    const glm::dvec3 d(ray.direction.x, ray.direction.y, ray.direction.z);
    const double b = glm::dot(o, d), c = glm::dot(o, o) - r * r;
    const double disc = b * b - c;
    return disc < 0.0 ? INFINITY : -b - std::sqrt(disc);
}

glm::dvec3 PatchNormalAt(const scene::Scene& s, const RcHit& h) {
    const scene::PatchBox& box = s.patchBoxes[h.prim - s.PatchBoxBase()];
    return glm::normalize(geometry::PatchNormal(box.p, h.u, h.v));
}

class NurbsSphere : public testing::TestWithParam<float> {};

// Where Newton from a box's centre fails: a ray that enters and leaves the sphere within one box
// (a glancing ray) has two roots there, and the iteration may find the far one or neither. Steep
// rays must all be right; the glancing failures are counted against a stated bound.
TEST_P(NurbsSphere, MatchesTheAnalyticSphere) {
    const float r = GetParam();
    Brute b{TestScene("nurbs_sphere.json", r)};
    const std::vector<RcRay> rays = RaysAtSphere(r, 3000, 11);
    const std::vector<RcHit> hits = NearestHits(TestContext(), *b.query, rays);
    uint32_t hitCount = 0, steepWrong = 0, glancingWrong = 0, wrongHit = 0;
    double worstT = 0.0, worstNormal = 0.0;
    for (size_t i = 0; i < rays.size(); ++i) {
        const double t = SphereT(rays[i], r);
        const glm::dvec3 d(rays[i].direction.x, rays[i].direction.y, rays[i].direction.z);
        const glm::dvec3 o(rays[i].origin.x, rays[i].origin.y, rays[i].origin.z);
        if (!std::isfinite(t)) {
            wrongHit += hits[i].prim != RC_NO_HIT;
            continue;
        }
        ++hitCount;
        const glm::dvec3 n = glm::normalize(o + t * d);
        const double cosine = std::fabs(glm::dot(n, d));
        if (hits[i].prim == RC_NO_HIT || std::fabs(double(hits[i].t) - t) > 1e-3 * r) {
            (cosine >= 0.7 ? steepWrong : glancingWrong) += 1;
            continue;
        }
        worstT = std::max(worstT, std::fabs(double(hits[i].t) - t) / r);
        worstNormal =
            std::max(worstNormal, 1.0 - std::fabs(glm::dot(PatchNormalAt(b.scene, hits[i]), n)));
    }
    std::printf(
        "scale %g: %u hits, %u glancing rays wrong, worst |dt|/r %.3g, worst "
        "1 - cos(normal) %.3g\n",
        double(r), hitCount, glancingWrong, worstT, worstNormal);
    EXPECT_GT(hitCount, 2000u);
    EXPECT_EQ(steepWrong, 0u);
    EXPECT_EQ(wrongHit, 0u);
    EXPECT_LE(glancingWrong, hitCount / 30);
    EXPECT_LE(worstT, 5e-5);       // hit distance within 5e-5 of the radius
    EXPECT_LE(worstNormal, 1e-6);  // normal within 0.08 degrees
}

INSTANTIATE_TEST_SUITE_P(Scales, NurbsSphere, testing::Values(1e-4f, 1.0f, 1e4f));

// Secondary rays start at the hit point moved off the surface as the renderer moves it; leaving
// a convex surface outwards they must not find it again.
TEST(NurbsSphereSurface, RaysLeavingTheSurfaceDoNotHitIt) {
    Brute b{TestScene("nurbs_sphere.json", 1.0f)};
    const std::vector<RcRay> eye = RaysAtSphere(1.0f, 2000, 12);
    const std::vector<RcHit> hits = NearestHits(TestContext(), *b.query, eye);
    std::mt19937 rng(13);
    std::uniform_real_distribution<float> uni(-1.0f, 1.0f);
    std::vector<RcRay> leaving;
    for (size_t i = 0; i < eye.size(); ++i) {
        // Only true front hits: a glancing ray's far root (see above) lies on the back.
        if (hits[i].prim == RC_NO_HIT || std::fabs(hits[i].t - SphereT(eye[i], 1.0)) > 1e-3) {
            continue;
        }
        const glm::vec3 o(eye[i].origin.x, eye[i].origin.y, eye[i].origin.z);
        const glm::vec3 d(eye[i].direction.x, eye[i].direction.y, eye[i].direction.z);
        const glm::vec3 p = o + hits[i].t * d;
        glm::vec3 n = glm::vec3(PatchNormalAt(b.scene, hits[i]));
        if (glm::dot(n, d) > 0.0f) n = -n;
        const glm::vec3 start = geometry::OffsetRayOrigin(p, n);
        for (int k = 0; k < 4; ++k) {
            // Outward directions, down to 1 degree above the tangent plane.
            glm::vec3 out(uni(rng), uni(rng), uni(rng));
            out -= glm::dot(out, n) * n;
            if (glm::length(out) < 1e-3f) continue;
            out = glm::normalize(glm::normalize(out) + (0.0175f + 0.5f * k) * n);
            leaving.push_back({{start.x, start.y, start.z, 0.0f}, {out.x, out.y, out.z, INFINITY}});
        }
    }
    ASSERT_GT(leaving.size(), 4000u);
    const std::vector<RcHit> again = NearestHits(TestContext(), *b.query, leaving);
    uint32_t self = 0;
    for (const RcHit& h : again) self += h.prim != RC_NO_HIT;
    EXPECT_EQ(self, 0u) << self << " of " << leaving.size() << " rays hit the sphere again";
}

// The torus: hits on the analytic torus (R = 1, r = 0.35, axis z) with its normal, and the same
// rays hit as the reference's subdivision finds.
TEST(NurbsTorus, HitsLieOnTheTorusAndMatchTheReference) {
    Brute b{TestScene("nurbs_torus.json", 1.0f)};
    const std::vector<RcRay> rays = RaysAtSphere(1.35f, 2000, 14);
    const std::vector<RcHit> hits = NearestHits(TestContext(), *b.query, rays);
    uint32_t refHits = 0, holes = 0, extra = 0;
    double worstSurface = 0.0, worstNormal = 0.0;
    for (size_t i = 0; i < rays.size(); ++i) {
        geometry::Ray<double> r;
        r.o = {rays[i].origin.x, rays[i].origin.y, rays[i].origin.z};
        r.d = {rays[i].direction.x, rays[i].direction.y, rays[i].direction.z};
        const auto ref = geometry::IntersectBruteForce(b.scene, r);
        refHits += ref.Valid();
        holes += ref.Valid() && hits[i].prim == RC_NO_HIT;
        extra += !ref.Valid() && hits[i].prim != RC_NO_HIT;
        if (hits[i].prim == RC_NO_HIT) continue;
        const glm::dvec3 p = r.o + double(hits[i].t) * r.d;
        const double ring = std::sqrt(p.x * p.x + p.y * p.y);
        const glm::dvec3 centre(p.x / ring, p.y / ring, 0.0);  // R = 1
        worstSurface = std::max(worstSurface, std::fabs(glm::length(p - centre) - 0.35));
        const glm::dvec3 n = glm::normalize(p - centre);
        worstNormal =
            std::max(worstNormal, 1.0 - std::fabs(glm::dot(PatchNormalAt(b.scene, hits[i]), n)));
    }
    std::printf(
        "torus: %u reference hits, %u holes, %u extra, worst surface distance %.3g, "
        "worst 1 - cos(normal) %.3g\n",
        refHits, holes, extra, worstSurface, worstNormal);
    EXPECT_GT(refHits, 800u);
    // Holes: glancing rays through a box that holds both their roots (see the sphere).
    EXPECT_LE(holes, refHits / 50);
    EXPECT_EQ(extra, 0u);
    EXPECT_LE(worstSurface, 2e-5);
    EXPECT_LE(worstNormal, 1e-6);
}

}  // namespace
}  // namespace rayclass::render
