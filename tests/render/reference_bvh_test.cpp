// The reference renderer's double-precision BVH against brute force in double and in float: every
// hit (id, distance, barycentrics) and every shadow answer equal, ray by ray, on random scenes
// built to be hard for a hierarchy (ties, flat and stacked primitives, axis-parallel rays) and on a
// sample of rays in Sibenik; and reference images rendered through it bit-identical to brute
// force's.
#include "rayclass/render/reference_bvh.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <ostream>
#include <random>
#include <string>
#include <vector>

#include "rayclass/geometry/intersect.h"
#include "rayclass/render/reference.h"
#include "rayclass/scene/loader.h"

namespace rayclass::render {
namespace {

using geometry::Hit;
using geometry::TriangleTest;
using DRay = geometry::Ray<double>;

std::filesystem::path SceneDir() {
    const char* source = std::getenv("RAYCLASS_SOURCE_DIR");
    return std::filesystem::path(source ? source : ".") / "scenes";
}

glm::vec3 RandomPoint(std::mt19937& rng, float lo, float hi) {
    std::uniform_real_distribution<float> u(lo, hi);
    return {u(rng), u(rng), u(rng)};
}

// Triangles of every size, duplicates (equal distances: the lower id must win), a stack of
// coplanar triangles in z = 0, spheres and clipped cylinders.
scene::Scene HardScene(uint32_t seed, uint32_t nTriangles) {
    std::mt19937 rng(seed);
    scene::Scene s;
    std::uniform_real_distribution<float> size(0.001f, 3.0f);
    for (uint32_t i = 0; i < nTriangles; ++i) {
        scene::Triangle t;
        const glm::vec3 c = RandomPoint(rng, -10.0f, 10.0f);
        const float r = size(rng);
        for (auto& p : t.p) p = c + r * RandomPoint(rng, -1.0f, 1.0f);
        if (i % 7 == 3) {
            for (auto& p : t.p) p.z = 0.0f;
        }
        s.triangles.push_back(t);
        if (i % 11 == 5) s.triangles.push_back(t);
    }
    for (int i = 0; i < 40; ++i) s.triangles.push_back(s.triangles[size_t(i) * 3]);
    for (int i = 0; i < 30; ++i) {
        scene::Sphere sp;
        sp.center = RandomPoint(rng, -10.0f, 10.0f);
        sp.radius = 0.05f + size(rng) / 2.0f;
        s.spheres.push_back(sp);
    }
    for (int i = 0; i < 10; ++i) {
        // (x - cx)^2 + (y - cy)^2 = r^2 clipped to a box around it.
        scene::Quadric q;
        const glm::vec3 c = RandomPoint(rng, -8.0f, 8.0f);
        const float r = 0.2f + size(rng) / 3.0f;
        q.c = {1, 1, 0, 0, 0, 0, -2 * c.x, -2 * c.y, 0, c.x * c.x + c.y * c.y - r * r};
        q.boxMin = c - glm::vec3(r, r, 1.5f);
        q.boxMax = c + glm::vec3(r, r, 1.5f);
        s.quadrics.push_back(q);
    }
    return s;
}

// Random rays from inside and outside the scene, rays with zero direction components, and rays
// aimed exactly at triangle corners (hits on shared edges and vertices).
std::vector<DRay> HardRays(const scene::Scene& s, uint32_t seed, size_t n) {
    std::mt19937 rng(seed);
    std::vector<DRay> rays;
    for (size_t i = 0; i < n; ++i) {
        const glm::dvec3 o(RandomPoint(rng, -14.0f, 14.0f));
        glm::dvec3 d(RandomPoint(rng, -1.0f, 1.0f));
        switch (i % 5) {
            case 1:
                d[i % 3] = 0.0;
                break;
            case 2:
                d = glm::dvec3(0.0), d[(i / 5) % 3] = (i & 8) ? 1.0 : -1.0;
                break;
            case 3:
                d = glm::dvec3(s.triangles[(i * 7919) % s.triangles.size()].p[i % 3]) - o;
                break;
            default:
                break;
        }
        if (d == glm::dvec3(0.0)) d.x = 1.0;
        rays.push_back(DRay{o, d});
    }
    return rays;
}

// Nearest and Occluded in T (float: the kernels' arithmetic; double: the reference renderer's).
template <typename T>
void ExpectSameAnswers(const scene::Scene& s, const std::vector<DRay>& doubleRays,
                       TriangleTest test) {
    const ReferenceBvh bvh(s, test);
    EXPECT_LE(bvh.LargestLeaf(), 4u);
    uint64_t tests = 0;
    size_t hits = 0, occluded = 0, mismatches = 0;
    std::vector<geometry::Ray<T>> rays;
    for (const DRay& r : doubleRays) {
        rays.push_back({glm::vec<3, T>(r.o), glm::vec<3, T>(r.d), T(r.tMin), T(r.tMax)});
    }
    for (size_t i = 0; i < rays.size(); ++i) {
        const geometry::Ray<T>& ray = rays[i];
        const Hit<T> want = geometry::IntersectBruteForce(s, ray, test);
        const Hit<T> got = bvh.Nearest(ray, tests);
        const bool same = got.prim == want.prim && std::memcmp(&got.t, &want.t, sizeof(T)) == 0 &&
                          std::memcmp(&got.u, &want.u, sizeof(T)) == 0 &&
                          std::memcmp(&got.v, &want.v, sizeof(T)) == 0;
        if (!same && ++mismatches <= 5) {
            ADD_FAILURE() << "ray " << i << ": bvh prim " << got.prim << " t " << got.t
                          << ", brute force prim " << want.prim << " t " << want.t;
        }
        hits += want.Valid();
        // Shadow segments ending before, at and beyond the nearest hit.
        const T ends[] = {want.Valid() ? want.t * T(0.999) : T(5), want.t, T(1e30)};
        for (T end : ends) {
            geometry::Ray<T> segment = ray;
            segment.tMax = end;
            const bool blocked = geometry::Occluded(s, segment, test);
            EXPECT_EQ(bvh.Occluded(segment, tests), blocked) << "ray " << i << " to " << end;
            occluded += blocked;
        }
    }
    EXPECT_EQ(mismatches, 0u);
    // The rays must exercise both outcomes, and the hierarchy must prune.
    EXPECT_GT(hits, rays.size() / 10);
    EXPECT_LT(hits, rays.size());
    EXPECT_GT(occluded, 0u);
    EXPECT_LT(tests, uint64_t(rays.size()) * s.PrimitiveCount());
}

TEST(ReferenceBvh, HitsEqualBruteForceOnHardRandomScenes) {
    for (uint32_t seed = 1; seed <= 2; ++seed) {
        const scene::Scene s = HardScene(seed, 3000);
        const std::vector<DRay> rays = HardRays(s, seed + 100, 2000);
        ExpectSameAnswers<double>(s, rays, TriangleTest::kMoller);
        ExpectSameAnswers<double>(s, rays, TriangleTest::kWatertight);
        ExpectSameAnswers<float>(s, rays, TriangleTest::kMoller);
        ExpectSameAnswers<float>(s, rays, TriangleTest::kWatertight);
    }
}

TEST(ReferenceBvh, IdenticalPrimitivesStayInSmallLeavesAndTheLowestIdWins) {
    scene::Scene s;
    scene::Triangle t;
    t.p = {glm::vec3(-1, -1, 0), glm::vec3(1, -1, 0), glm::vec3(0, 1, 0)};
    s.triangles.assign(1000, t);
    const ReferenceBvh bvh(s, TriangleTest::kMoller);
    EXPECT_LE(bvh.LargestLeaf(), 4u);
    uint64_t tests = 0;
    const Hit<double> hit = bvh.Nearest(DRay{{0.1, 0.1, 5.0}, {0.0, 0.0, -1.0}}, tests);
    EXPECT_EQ(hit.prim, 0u);
    EXPECT_EQ(hit.t, 5.0);
}

TEST(ReferenceBvh, EmptySceneHasNoHits) {
    const scene::Scene s;
    const ReferenceBvh bvh(s, TriangleTest::kMoller);
    uint64_t tests = 0;
    EXPECT_FALSE(bvh.Nearest(DRay{{0, 0, 0}, {0, 0, 1}}, tests).Valid());
    EXPECT_FALSE(bvh.Occluded(DRay{{0, 0, 0}, {0, 0, 1}, 0.0, 10.0}, tests));
}

// A sample of Sibenik's rays: from the benchmark camera into random directions and from random
// points of the cathedral, where brute force over 75,284 triangles still answers quickly.
TEST(ReferenceBvh, HitsEqualBruteForceOnSibenikSample) {
    const scene::Scene s = scene::LoadScene(SceneDir() / "bench/sibenik_mirror.json");
    std::mt19937 rng(7);
    const auto box = s.Bounds();
    std::vector<DRay> rays;
    for (int i = 0; i < 300; ++i) {
        const glm::vec3 d = RandomPoint(rng, -1.0f, 1.0f);
        glm::vec3 o = s.camera.position;
        if (i % 2) {
            std::uniform_real_distribution<float> ux(box.lo.x, box.hi.x), uy(box.lo.y, box.hi.y),
                uz(box.lo.z, box.hi.z);
            o = {ux(rng), uy(rng), uz(rng)};
        }
        rays.push_back(DRay{glm::dvec3(o), glm::dvec3(d)});
    }
    ExpectSameAnswers<double>(s, rays, TriangleTest::kMoller);
    ExpectSameAnswers<float>(s, rays, TriangleTest::kMoller);
}

struct ImageCase {
    std::string file;
    TriangleTest test;
};

void PrintTo(const ImageCase& c, std::ostream* os) {
    *os << c.file << (c.test == TriangleTest::kWatertight ? " watertight" : " moller");
}

class ReferenceBvhImage : public testing::TestWithParam<ImageCase> {};

// Every layer of the image, byte for byte.
TEST_P(ReferenceBvhImage, IdenticalToBruteForce) {
    scene::Scene s = scene::LoadScene(SceneDir() / GetParam().file);
    s.camera.width = 200;
    s.camera.height = 150;
    RenderOptions options;
    options.aovs = true;
    options.progress = false;
    options.triangleTest = GetParam().test;
    RenderStats bvhStats, bruteStats;
    const image::Image bvh = RenderReference(s, options, bvhStats, ReferenceQuery::kBvh);
    const image::Image brute = RenderReference(s, options, bruteStats, ReferenceQuery::kBruteForce);
    auto same = [](const auto& a, const auto& b) {
        return a.size() == b.size() &&
               std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0;
    };
    EXPECT_TRUE(same(bvh.rgb, brute.rgb));
    EXPECT_TRUE(same(bvh.depth, brute.depth));
    EXPECT_TRUE(same(bvh.id, brute.id));
    EXPECT_TRUE(same(bvh.normal, brute.normal));
    EXPECT_EQ(bvhStats.raysByKind, bruteStats.raysByKind);
    EXPECT_EQ(bvhStats.accel, "bvh");
    EXPECT_EQ(bruteStats.accel, "brute");
}

INSTANTIATE_TEST_SUITE_P(Scenes, ReferenceBvhImage,
                         testing::Values(ImageCase{"cornell.json", TriangleTest::kMoller},
                                         ImageCase{"cornell.json", TriangleTest::kWatertight},
                                         ImageCase{"tests/spheres.json", TriangleTest::kMoller},
                                         ImageCase{"tests/quadrics.json", TriangleTest::kMoller},
                                         ImageCase{"tests/glass.json", TriangleTest::kWatertight},
                                         ImageCase{"tests/nurbs_torus.json", TriangleTest::kMoller}),
                         [](const testing::TestParamInfo<ImageCase>& info) {
                             std::string name =
                                 std::filesystem::path(info.param.file).stem().string();
                             return name + (info.param.test == TriangleTest::kWatertight
                                                ? "_watertight"
                                                : "_moller");
                         });

}  // namespace
}  // namespace rayclass::render
