// The BVH's kernels against brute force's where a slab test is fragile: axis-parallel directions
// (zero components, whose inverses are infinite) and rays lying in the planes of the scene's faces,
// in a grid of axis-aligned squares whose node boxes share those planes. The hits must be the
// same: primitive, distance and barycentrics for nearest hits, the answer for any-hit queries.
// When it was written, unpadded node boxes failed it (rays in the squares' planes missed them),
// and so did skipping boxes entered exactly at the nearest hit's distance (a higher id won ties
// at shared edges). The same rays in coherent runs of 16 take the kernels' packet walk.
#include "rayclass/render/bvh_query.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "clrt/device.h"
#include "quad.h"
#include "query_io.h"
#include "rayclass/bvh/bvh.h"
#include "rayclass/clrt/context.h"
#include "rayclass/render/brute_query.h"
#include "rayclass/render/device_scene.h"
#include "shadow_ray.h"

namespace rayclass::render {
namespace {

using clrt::testing::TestContext;

// Unit squares, two triangles each, in the planes x = k, y = k and z = k (k = 0..3) over [0, 3]^2.
scene::Scene GridOfSquares() {
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
                    AddQuad(s, at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                }
            }
        }
    }
    return s;
}

// From every point of a half-unit lattice over [-0.5, 3.5]^3 (on the squares' planes at the whole
// units), along the 26 lattice directions; from points on the faces of the tree's (padded) boxes
// along directions in those faces' planes, where a slab distance is 0 times the infinite inverse
// of the zero direction component; then random rays through the grid.
std::vector<RcRay> FragileRays(const scene::Scene& scene, float tmax) {
    std::vector<RcRay> rays;
    for (const bvh::BinaryNode& node : bvh::Build(scene).nodes) {
        for (int axis = 0; axis < 3; ++axis) {
            for (float plane : {node.box.lo[axis], node.box.hi[axis]}) {
                glm::vec3 o = node.box.Center();
                o[axis] = plane;
                for (int a = -1; a <= 1; ++a) {
                    for (int b = -1; b <= 1; ++b) {
                        if (a == 0 && b == 0) continue;
                        glm::vec3 d(0.0f);
                        d[(axis + 1) % 3] = float(a);
                        d[(axis + 2) % 3] = float(b);
                        d = glm::normalize(d);
                        rays.push_back({{o.x, o.y, o.z, 1e-4f}, {d.x, d.y, d.z, tmax}});
                    }
                }
            }
        }
    }
    for (int x = -1; x <= 7; ++x) {
        for (int y = -1; y <= 7; ++y) {
            for (int z = -1; z <= 7; ++z) {
                for (int dx = -1; dx <= 1; ++dx) {
                    for (int dy = -1; dy <= 1; ++dy) {
                        for (int dz = -1; dz <= 1; ++dz) {
                            if (dx == 0 && dy == 0 && dz == 0) continue;
                            const glm::vec3 d = glm::normalize(glm::vec3(dx, dy, dz));
                            rays.push_back(
                                {{0.5f * x, 0.5f * y, 0.5f * z, 1e-4f}, {d.x, d.y, d.z, tmax}});
                        }
                    }
                }
            }
        }
    }
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> pos(-0.5f, 3.5f), dir(-1.0f, 1.0f);
    for (int i = 0; i < 4096; ++i) {
        const glm::vec3 d = glm::normalize(glm::vec3(dir(rng), dir(rng), dir(rng)));
        rays.push_back({{pos(rng), pos(rng), pos(rng), 1e-4f}, {d.x, d.y, d.z, tmax}});
    }
    return rays;
}

// Packets of 16 consecutive rays that the kernels walk as one (cl/bvh.cl): from every point of
// the half-unit lattice along each of the 26 lattice directions in turn (so each run of 16 shares
// its direction, many of them axis-parallel or in the squares' planes), then runs of 16 random
// origins with directions jittered within a few degrees of a random one. Every fifth ray has
// tmax 0 when `emptySlots`: the empty shadow slots the any-hit kernel skips.
std::vector<RcRay> CoherentRays(float tmax, bool emptySlots) {
    std::vector<RcRay> rays;
    for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
            for (int dz = -1; dz <= 1; ++dz) {
                if (dx == 0 && dy == 0 && dz == 0) continue;
                const glm::vec3 d = glm::normalize(glm::vec3(dx, dy, dz));
                for (int x = -1; x <= 7; ++x) {
                    for (int y = -1; y <= 7; ++y) {
                        for (int z = -1; z <= 7; ++z) {
                            rays.push_back(
                                {{0.5f * x, 0.5f * y, 0.5f * z, 1e-4f}, {d.x, d.y, d.z, tmax}});
                        }
                    }
                }
            }
        }
    }
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> pos(-0.5f, 3.5f), dir(-1.0f, 1.0f), jitter(-0.02f, 0.02f);
    for (int packet = 0; packet < 512; ++packet) {
        const glm::vec3 base = glm::normalize(glm::vec3(dir(rng), dir(rng), dir(rng)));
        for (int k = 0; k < 16; ++k) {
            const glm::vec3 d =
                glm::normalize(base + glm::vec3(jitter(rng), jitter(rng), jitter(rng)));
            rays.push_back({{pos(rng), pos(rng), pos(rng), 1e-4f}, {d.x, d.y, d.z, tmax}});
        }
    }
    if (emptySlots) {
        for (size_t i = 0; i < rays.size(); i += 5) rays[i].direction.w = 0.0f;
    }
    return rays;
}

// Every fifth slot emptied (a zero direction), as the renderer leaves slots of rays not spawned.
void EmptyEveryFifthSlot(std::vector<RcRay>& rays) {
    for (size_t i = 0; i < rays.size(); i += 5) rays[i].direction = {0.0f, 0.0f, 0.0f, 0.0f};
}

// Packets of 16 shadow rays as the shading kernels make them (tmin 0, unit direction toward a
// point light, tmax the distance to it), their origins within a 0.02 cube and their light 0.3 to
// 1.2 away, so that the any-hit kernel walks each packet as one beam from its light (cl/bvh.cl).
// Lights on the half-unit lattice (in the squares' planes) and at random points; origins in a
// square's plane, on the light's axis line (directions along an axis, zero components) or
// anywhere; every fifth slot empty.
std::vector<RcRay> ShadowPackets() {
    std::mt19937 rng(13);
    std::uniform_real_distribution<float> pos(-0.5f, 3.5f), unit(-1.0f, 1.0f),
        jitter(-0.01f, 0.01f), reach(0.3f, 1.2f);
    std::uniform_int_distribution<int> lattice(-1, 7), axisOf(0, 2), kindOf(0, 2);
    std::vector<RcRay> rays;
    for (int packet = 0; packet < 1024; ++packet) {
        const glm::vec3 light = packet % 2 == 0
                                    ? 0.5f * glm::vec3(lattice(rng), lattice(rng), lattice(rng))
                                    : glm::vec3(pos(rng), pos(rng), pos(rng));
        const glm::vec3 away = glm::normalize(glm::vec3(unit(rng), unit(rng), unit(rng)));
        const int kind = kindOf(rng), axis = axisOf(rng);
        glm::vec3 center = light + reach(rng) * away;
        if (kind == 0) center[axis] = std::round(center[axis]);  // a square's plane
        if (kind == 1) {                                         // on the light's axis line
            center = light;
            center[axis] += (packet % 3 == 0 ? -1.0f : 1.0f) * reach(rng);
        }
        for (int k = 0; k < 16; ++k) {
            glm::vec3 o = center;
            for (int c = 0; c < 3; ++c) {
                if ((kind == 0 && c != axis) || (kind == 1 && c == axis) || kind == 2)
                    o[c] += jitter(rng);
            }
            rays.push_back(ShadowRay(o, light));
        }
    }
    EmptyEveryFifthSlot(rays);
    return rays;
}

// Shadow rays from origins scattered over the grid toward three point lights, a slot per light
// side by side (as the renderer lays them out), every fifth slot empty: in their own order no
// packet is coherent, so the BVH sorts them by direction from their light and walks the
// packets of that order as beams (ShadowOrder, cl/bvh.cl).
std::vector<RcRay> ScatteredShadowRays() {
    std::mt19937 rng(17);
    std::uniform_real_distribution<float> pos(-0.5f, 3.5f);
    const glm::vec3 lights[3] = {{1.5f, 1.5f, 1.5f}, {0.25f, 3.0f, 2.75f}, {2.0f, 0.5f, 0.0f}};
    std::vector<RcRay> rays;
    for (int i = 0; i < 6000; ++i) {
        const glm::vec3 o(pos(rng), pos(rng), pos(rng));
        for (const glm::vec3& light : lights) rays.push_back(ShadowRay(o, light));
    }
    EmptyEveryFifthSlot(rays);
    return rays;
}

// Rays from random points of the grid in random directions, their reach random too (every
// other ray unlimited, every fifth slot empty when `emptySlots`), and a count that leaves the last
// packet of 16 short and odd: no packet is walked as one, so the kernels take the single-ray walk
// for each ray, walks that end after very different numbers of steps (cl/bvh.cl).
std::vector<RcRay> ScatteredRaysOfMixedReach(bool emptySlots) {
    std::mt19937 rng(21);
    std::uniform_real_distribution<float> pos(-0.5f, 3.5f), dir(-1.0f, 1.0f), reach(0.05f, 3.0f);
    std::vector<RcRay> rays;
    for (int i = 0; i < 16 * 400 + 7; ++i) {
        const glm::vec3 d = glm::normalize(glm::vec3(dir(rng), dir(rng), dir(rng)));
        const float tmax = i % 2 == 0 ? INFINITY : reach(rng);
        rays.push_back({{pos(rng), pos(rng), pos(rng), 1e-4f}, {d.x, d.y, d.z, tmax}});
    }
    if (emptySlots) EmptyEveryFifthSlot(rays);
    return rays;
}

// Packets of 16 rays from random points of the grid, each lane's direction turned 20 degrees
// from the lane before it about a random axis: no 12 lanes lie within 30 degrees of the packet's
// first or last ray, but every lane within 30 degrees of the one before it, so the nearest-hit
// kernel walks each packet as bundled (rc_bvh_packet_bundled, cl/bvh.cl), as its two halves of
// eight lanes (rc_bvh_trace_halves), over rays in every octant.
std::vector<RcRay> TurningPackets() {
    std::mt19937 rng(29);
    std::uniform_real_distribution<float> pos(-0.5f, 3.5f), dir(-1.0f, 1.0f);
    std::vector<RcRay> rays;
    for (int packet = 0; packet < 300; ++packet) {
        const glm::vec3 o(pos(rng), pos(rng), pos(rng));
        const glm::vec3 axis = glm::normalize(glm::vec3(dir(rng), dir(rng), dir(rng)));
        glm::vec3 d = glm::normalize(glm::cross(axis, glm::vec3(dir(rng), dir(rng), dir(rng))));
        const glm::vec3 side = glm::cross(axis, d);
        for (int k = 0; k < 16; ++k) {
            const float a = glm::radians(20.0f) * float(k);
            const glm::vec3 dk = std::cos(a) * d + std::sin(a) * side;
            rays.push_back({{o.x, o.y, o.z, 1e-4f}, {dk.x, dk.y, dk.z, INFINITY}});
        }
    }
    return rays;
}

struct Queries {
    scene::Scene scene = GridOfSquares();
    cl::Program program = BuildRenderProgram(TestContext());
    SceneBuffers buffers{TestContext(), scene, Params()};
    std::unique_ptr<RayQuery> bvh = MakeBvhQuery(TestContext(), program, buffers, scene);
    std::unique_ptr<RayQuery> brute = MakeBruteForceQuery(TestContext(), program, buffers);

    RcRenderParams Params() const {
        RcRenderParams p{};
        p.nTriangles = uint32_t(scene.triangles.size());
        return p;
    }
};

// Nearest hits of `rays` by the BVH and by brute force must be equal: primitive, t, u and v.
void ExpectBruteForcesHits(Queries& q, const std::vector<RcRay>& rays) {
    const std::vector<RcHit> bvh = NearestHits(TestContext(), *q.bvh, rays),
                             brute = NearestHits(TestContext(), *q.brute, rays);
    uint32_t hits = 0, mismatches = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        hits += brute[i].prim != RC_NO_HIT;
        const bool same =
            bvh[i].prim == brute[i].prim &&
            (brute[i].prim == RC_NO_HIT ||
             (bvh[i].t == brute[i].t && bvh[i].u == brute[i].u && bvh[i].v == brute[i].v));
        if (!same && ++mismatches <= 10) {
            ADD_FAILURE() << "ray " << i << " from (" << rays[i].origin.x << ", "
                          << rays[i].origin.y << ", " << rays[i].origin.z << ") along ("
                          << rays[i].direction.x << ", " << rays[i].direction.y << ", "
                          << rays[i].direction.z << "): bvh " << bvh[i].prim << " at " << bvh[i].t
                          << ", brute force " << brute[i].prim << " at " << brute[i].t;
        }
    }
    EXPECT_EQ(mismatches, 0u);
    EXPECT_GT(hits, rays.size() / 3);  // the rays do meet the grid
}

// The any-hit answers of `rays` by the BVH and by brute force must be equal.
void ExpectBruteForcesBlocked(Queries& q, const std::vector<RcRay>& rays) {
    const std::vector<uint8_t> bvh = BlockedAnswers(TestContext(), *q.bvh, rays),
                               brute = BlockedAnswers(TestContext(), *q.brute, rays);
    uint32_t blocked = 0, mismatches = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        blocked += brute[i] != 0;
        mismatches += (bvh[i] != 0) != (brute[i] != 0);
    }
    EXPECT_EQ(mismatches, 0u);
    EXPECT_GT(blocked, rays.size() / 10);
    EXPECT_LT(blocked, rays.size() - rays.size() / 10);
}

TEST(BvhQuery, AxisParallelRaysAndRaysInFacePlanesHitWhatBruteForceHits) {
    Queries q;
    ExpectBruteForcesHits(q, FragileRays(q.scene, INFINITY));
}

TEST(BvhQuery, PacketsOfCoherentRaysHitWhatBruteForceHits) {
    Queries q;
    ExpectBruteForcesHits(q, CoherentRays(INFINITY, false));
}

TEST(BvhQuery, PacketsOfRaysTurningLaneByLaneHitWhatBruteForceHits) {
    Queries q;
    ExpectBruteForcesHits(q, TurningPackets());
}

TEST(BvhQuery, PacketsOfCoherentRaysAreBlockedAsByBruteForce) {
    Queries q;
    ExpectBruteForcesBlocked(q, CoherentRays(0.75f, true));
}

TEST(BvhQuery, AnyHitAnswersOfFragileRaysAreBruteForces) {
    Queries q;
    ExpectBruteForcesBlocked(q, FragileRays(q.scene, 0.75f));
}

TEST(BvhQuery, ShadowPacketsTowardPointLightsAreBlockedAsByBruteForce) {
    Queries q;
    ExpectBruteForcesBlocked(q, ShadowPackets());
}

TEST(BvhQuery, ScatteredShadowRaysTowardPointLightsAreBlockedAsByBruteForce) {
    Queries q;
    ExpectBruteForcesBlocked(q, ScatteredShadowRays());
}

TEST(BvhQuery, ScatteredRaysOfMixedReachHitWhatBruteForceHits) {
    Queries q;
    ExpectBruteForcesHits(q, ScatteredRaysOfMixedReach(false));
}

TEST(BvhQuery, ScatteredRaysOfMixedReachAreBlockedAsByBruteForce) {
    Queries q;
    ExpectBruteForcesBlocked(q, ScatteredRaysOfMixedReach(true));
}

}  // namespace
}  // namespace rayclass::render
