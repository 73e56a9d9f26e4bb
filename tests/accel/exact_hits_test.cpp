// Every acceleration against brute force, the oracle: on every test scene and on a mesh of 75k
// triangles, for the eye rays of the scene's camera and the shadow, reflection, refraction and
// diffuse rays spawned from their hits, the nearest hits must be brute force's bit for bit
// (primitive, distance, barycentrics; the lower id wins ties in both) and the any-hit answers
// the same. Rays are sampled (a small image) to keep brute force fast.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "accel_support.h"
#include "rayclass/accel/cones.h"
#include "rayclass/scene/loader.h"

namespace rayclass::accel {
namespace {

struct Case {
    const char* scene;
    uint32_t width, height;
};

// The test scenes, the default scene and the 75k-triangle bunny (fewer rays: brute force pays
// 75k tests a ray).
const Case kCases[] = {{"scenes/cornell.json", 48, 36},
                       {"scenes/tests/glass.json", 48, 36},
                       {"scenes/tests/quadrics.json", 48, 36},
                       {"scenes/tests/spheres.json", 48, 36},
                       {"scenes/tests/floor.obj", 48, 36},
                       {"scenes/teapot.json", 48, 36},
                       {"scenes/tests/nurbs_sphere.json", 48, 36},
                       {"scenes/tests/nurbs_torus.json", 48, 36},
                       {"scenes/bench/bunny.obj", 24, 18}};

// Mismatches of `q` against brute force on `rays` as nearest-hit rays; `hits` counts brute
// force's hits.
uint32_t NearestMismatches(const Loaded& l, render::RayQuery& q, const std::vector<RcRay>& rays,
                           uint32_t* hits, const std::string& what) {
    const std::vector<RcHit> got = render::NearestHits(Ctx(), q, rays),
                             want = render::NearestHits(Ctx(), *l.brute, rays);
    uint32_t mismatches = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        *hits += want[i].prim != RC_NO_HIT;
        const bool same =
            got[i].prim == want[i].prim &&
            (want[i].prim == RC_NO_HIT ||
             (got[i].t == want[i].t && got[i].u == want[i].u && got[i].v == want[i].v));
        if (!same && ++mismatches <= 5) {
            ADD_FAILURE() << what << " ray " << i << " from (" << rays[i].origin.x << ", "
                          << rays[i].origin.y << ", " << rays[i].origin.z << ") along ("
                          << rays[i].direction.x << ", " << rays[i].direction.y << ", "
                          << rays[i].direction.z << "): " << q.Name() << " " << got[i].prim
                          << " at " << got[i].t << ", brute force " << want[i].prim << " at "
                          << want[i].t;
        }
    }
    return mismatches;
}

// Brute force's hits among the eye rays of a set, and how many there are.
struct EyeHits {
    uint32_t hits = 0;
    size_t rays = 0;
};

// The eye rays `eye` (`width` of them a row) and the rays spawned from brute force's hits on
// them, toward `light` for shadow rays: every kind answered by `backend` as brute force answers
// it. `label` starts each failure's description.
EyeHits ExpectSpawnedLikeBruteForce(const Loaded& l, const std::string& backend,
                                    const std::vector<bench::BenchRay>& eye, const glm::vec3& light,
                                    uint32_t width, const std::string& label) {
    const std::vector<RcHit> eyeHits = render::NearestHits(Ctx(), *l.brute, ToRc(eye));
    std::vector<bench::BenchHit> benchHits;
    for (const RcHit& h : eyeHits) benchHits.push_back({h.t, h.prim});
    const bench::RaySets sets = bench::MakeRaySets(l.scene, eye, benchHits, light, 7, width);
    const auto query = l.Make(backend);
    EyeHits eyeKind;
    for (int k = 0; k < bench::kNumKinds; ++k) {
        const std::vector<RcRay> rays = ToRc(sets.sets[k]);
        if (rays.empty()) continue;
        const std::string what = label + bench::kKinds[k];
        if (bench::IsShadowKind(k)) {
            const auto got = render::BlockedAnswers(Ctx(), *query, rays);
            const auto want = render::BlockedAnswers(Ctx(), *l.brute, rays);
            uint32_t mismatches = 0;
            for (size_t i = 0; i < rays.size(); ++i) mismatches += got[i] != want[i];
            EXPECT_EQ(mismatches, 0u) << what;
        } else {
            uint32_t hits = 0;
            EXPECT_EQ(NearestMismatches(l, *query, rays, &hits, what), 0u) << what;
            if (k == 0) eyeKind = {hits, rays.size()};
        }
    }
    return eyeKind;
}

class ExactHits : public ::testing::TestWithParam<std::string> {};

TEST_P(ExactHits, EveryRayKindOfEveryTestSceneHitsWhatBruteForceHits) {
    for (const Case& c : kCases) {
        SCOPED_TRACE(c.scene);
        const Loaded l(scene::LoadScene(SourceDir() / c.scene));
        const auto query = l.Make(GetParam());
        const bench::RaySets sets = SampledRaySets(l, c.width, c.height);
        for (int k = 0; k < bench::kNumKinds; ++k) {
            const std::vector<RcRay> rays = ToRc(sets.sets[k]);
            if (rays.empty()) continue;
            const std::string what = std::string(c.scene) + " " + bench::kKinds[k];
            if (bench::IsShadowKind(k)) {
                uint64_t tests = 0;
                const auto got = render::BlockedAnswers(Ctx(), *query, rays, &tests);
                const auto want = render::BlockedAnswers(Ctx(), *l.brute, rays);
                uint32_t mismatches = 0;
                for (size_t i = 0; i < rays.size(); ++i) mismatches += got[i] != want[i];
                EXPECT_EQ(mismatches, 0u) << what;
                EXPECT_GT(tests, 0u) << what;
            } else {
                uint32_t hits = 0;
                EXPECT_EQ(NearestMismatches(l, *query, rays, &hits, what), 0u) << what;
                if (k == 0) {
                    EXPECT_GT(hits, 0u) << what;
                }
            }
        }
    }
}

// Eye rays fine enough that 16 consecutive ones make a coherent packet (rc_bvh_load_packet's
// test), which the kd-tree and grid kernels walk together, and the rays spawned from their hits:
// eight middle rows of a 96x72 image of the bunny (the small images above are too coarse for any
// packet to pass the test). The cones need no such rays: their kernels answer every tile's rays
// sixteen at a time whatever the rays.
TEST_P(ExactHits, CoherentPacketsHitWhatBruteForceHits) {
    if (GetParam() == "cones") GTEST_SKIP() << "the cones' packets are tested by every test";
    const Loaded l(scene::LoadScene(SourceDir() / "scenes/bench/bunny.obj"));
    const scene::Camera cam = bench::NamedCamera(l.scene, "scene", 96, 72);
    const std::vector<bench::BenchRay> all = bench::EyeRays(cam);
    const std::vector<bench::BenchRay> eye(all.begin() + 96 * 32, all.begin() + 96 * 40);
    const EyeHits e = ExpectSpawnedLikeBruteForce(
        l, GetParam(), eye, l.scene.lights.empty() ? cam.position : l.scene.lights[0].position, 96,
        "bunny 96x72 ");
    if (e.rays > 0) {
        EXPECT_GT(e.hits, e.rays / 4) << "bunny 96x72 " << bench::kKinds[0];
    }
}

// Full-size scanlines, 16 rows of a 1024x768 image of the default scene and the rays spawned
// from their hits: the cones keep such a batch in its own order (CoherentAsGiven) instead of
// sorting it.
TEST_P(ExactHits, FullSizeScanlinesHitWhatBruteForceHits) {
    const Loaded l(scene::LoadScene(SourceDir() / "scenes/cornell.json"));
    const scene::Camera cam = bench::NamedCamera(l.scene, "scene", 1024, 768);
    const std::vector<bench::BenchRay> all = bench::EyeRays(cam);
    const std::vector<bench::BenchRay> eye(all.begin() + 1024 * 376, all.begin() + 1024 * 392);
    ASSERT_TRUE(accel::CoherentAsGiven(ToRc(eye)));
    ExpectSpawnedLikeBruteForce(l, GetParam(), eye, l.scene.lights[0].position, 1024,
                                "cornell 1024x768 ");
}

// Rays from a half-unit lattice (on the planes of a grid of unit squares) along the 26 lattice
// directions, many of them axis-parallel or in the squares' planes, and random rays: where a
// structure's cell boundaries coincide with the geometry, rounding decides.
TEST_P(ExactHits, AxisParallelRaysInFacePlanesHitWhatBruteForceHits) {
    scene::Scene s;
    for (int axis = 0; axis < 3; ++axis) {
        for (int k = 0; k <= 3; ++k) {
            for (int i = 0; i < 3; ++i) {
                for (int j = 0; j < 3; ++j) {
                    auto at = [&](int a, int b) {
                        glm::vec3 p;
                        p[axis] = float(k);
                        p[(axis + 1) % 3] = float(a);
                        p[(axis + 2) % 3] = float(b);
                        return p;
                    };
                    scene::Triangle t;
                    t.p = {at(i, j), at(i + 1, j), at(i + 1, j + 1)};
                    s.triangles.push_back(t);
                    t.p = {at(i, j), at(i + 1, j + 1), at(i, j + 1)};
                    s.triangles.push_back(t);
                }
            }
        }
    }
    s.spheres.push_back({{1.5f, 1.5f, 1.5f}, 0.5f, 0, 0});
    const Loaded l(std::move(s));
    std::vector<RcRay> rays;
    for (int x = -1; x <= 7; ++x) {
        for (int y = -1; y <= 7; ++y) {
            for (int z = -1; z <= 7; ++z) {
                for (int dx = -1; dx <= 1; ++dx) {
                    for (int dy = -1; dy <= 1; ++dy) {
                        for (int dz = -1; dz <= 1; ++dz) {
                            if (dx == 0 && dy == 0 && dz == 0) continue;
                            const glm::vec3 d = glm::normalize(glm::vec3(dx, dy, dz));
                            rays.push_back(
                                {{0.5f * x, 0.5f * y, 0.5f * z, 1e-4f}, {d.x, d.y, d.z, INFINITY}});
                        }
                    }
                }
            }
        }
    }
    const auto query = l.Make(GetParam());
    uint32_t hits = 0;
    EXPECT_EQ(NearestMismatches(l, *query, rays, &hits, "lattice"), 0u);
    EXPECT_GT(hits, rays.size() / 3);
    for (RcRay& r : rays) r.direction.w = 0.75f;
    const auto got = render::BlockedAnswers(Ctx(), *query, rays);
    const auto want = render::BlockedAnswers(Ctx(), *l.brute, rays);
    uint32_t mismatches = 0, blocked = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        mismatches += got[i] != want[i];
        blocked += want[i] != 0;
    }
    EXPECT_EQ(mismatches, 0u);
    EXPECT_GT(blocked, rays.size() / 10);
}

INSTANTIATE_TEST_SUITE_P(Accel, ExactHits, ::testing::Values("kdtree", "grid", "cones"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace rayclass::accel
