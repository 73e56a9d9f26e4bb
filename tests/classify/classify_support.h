// Scenes, parameters and checks the classify suites share.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "rayclass/classify/hierarchy.h"
#include "rayclass/classify/query.h"
#include "rayclass/geometry/offset.h"

namespace rayclass::classify {

using geometry::Hit;

inline scene::Triangle MakeTriangle(glm::vec3 a, glm::vec3 b, glm::vec3 c) {
    scene::Triangle t;
    t.p = {a, b, c};
    return t;
}

// Random small triangles in [-1, 1]^3, a few spheres and a clipped ellipsoid.
inline scene::Scene RandomScene(uint32_t seed, int nTriangles, int nSpheres, int nQuadrics) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(-1.0f, 1.0f), off(-0.3f, 0.3f), rad(0.05f, 0.2f);
    scene::Scene s;
    for (int i = 0; i < nTriangles; ++i) {
        const glm::vec3 c(pos(rng), pos(rng), pos(rng));
        s.triangles.push_back(MakeTriangle(c + glm::vec3(off(rng), off(rng), off(rng)),
                                           c + glm::vec3(off(rng), off(rng), off(rng)),
                                           c + glm::vec3(off(rng), off(rng), off(rng))));
    }
    for (int i = 0; i < nSpheres; ++i) {
        s.spheres.push_back({glm::vec3(pos(rng), pos(rng), pos(rng)), rad(rng)});
    }
    for (int i = 0; i < nQuadrics; ++i) {
        scene::Quadric q;
        const glm::vec3 c(pos(rng), pos(rng), pos(rng));
        const float r = rad(rng);
        // (x - cx)^2 + (y - cy)^2 + 4 (z - cz)^2 = r^2, clipped to its box's upper half in y.
        q.c = {1, 1,        4,        0,        0,
               0, -2 * c.x, -2 * c.y, -8 * c.z, c.x * c.x + c.y * c.y + 4 * c.z * c.z - r * r};
        q.boxMin = c - glm::vec3(r, 0.0f, r);
        q.boxMax = c + glm::vec3(r);
        s.quadrics.push_back(q);
    }
    return s;
}

// Parameters that split small ray sets deeply, so that small tests exercise deep hierarchies,
// with planned splits near the roots.
inline Params DeepParams(const scene::Scene& s) {
    Params p = Params::ForScene(s);
    p.planRays = 256;
    p.minRays = 4;
    p.minCandidates = 2;
    p.lightMinCandidates = 2;
    p.splitGain = 1.0f;
    p.boxTestCost = 0.01f;
    p.rayMoveCost = 0.01f;
    return p;
}

inline std::vector<Hit<float>> BruteForce(const scene::Scene& s, const std::vector<Ray>& rays) {
    std::vector<Hit<float>> hits;
    for (const Ray& r : rays) hits.push_back(geometry::IntersectBruteForce(s, ToGeometryRay(r)));
    return hits;
}

// Same primitive; same distance. Both paths run the same float routine on the same ray, so the
// distances agree exactly; the tolerance of 1 ulp of t only guards against a future change of
// operation order.
inline void ExpectSameHits(const std::vector<Hit<float>>& a, const std::vector<Hit<float>>& b) {
    ASSERT_EQ(a.size(), b.size());
    int nDiffer = 0;
    for (size_t i = 0; i < a.size(); ++i) {
        const bool same =
            a[i].prim == b[i].prim &&
            (!a[i].Valid() ||
             std::abs(a[i].t - b[i].t) <= std::abs(std::nextafter(a[i].t, INFINITY) - a[i].t));
        if (!same && ++nDiffer <= 5) {
            ADD_FAILURE() << "ray " << i << ": prim " << a[i].prim << " t " << a[i].t << " vs prim "
                          << b[i].prim << " t " << b[i].t;
        }
    }
    EXPECT_EQ(nDiffer, 0);
}

inline std::vector<Hit<float>> Query(const scene::Scene& s, const LeafBatch& batch,
                                     const std::vector<Ray>& rays) {
    std::vector<Hit<float>> hits(rays.size());
    QueryHost(s, batch, rays, hits);
    return hits;
}

inline glm::vec3 RandomDirection(std::mt19937& rng) {
    std::normal_distribution<float> n;
    glm::vec3 d;
    do d = glm::vec3(n(rng), n(rng), n(rng));
    while (glm::length(d) < 1e-3f);
    return glm::normalize(d);
}

// Shadow rays as the renderer makes them: slot i * lights.size() + l runs from just above the
// surface that eye-like ray i hits to light l; every seventh slot is empty (no direction), as for
// a light behind the surface.
inline std::vector<Ray> ShadowSlots(const scene::Scene& s, const std::vector<glm::vec3>& lights,
                                    uint32_t seed, int n) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(-1.2f, 1.2f);
    std::vector<Ray> out;
    for (int i = 0; out.size() < size_t(n) * lights.size(); ++i) {
        Ray eye;
        eye.origin = glm::vec3(pos(rng), pos(rng), -1.5f);
        eye.direction = RandomDirection(rng);
        const Hit<float> h = geometry::IntersectBruteForce(s, ToGeometryRay(eye));
        if (!h.Valid()) continue;
        const glm::vec3 p = eye.origin + h.t * eye.direction;
        for (size_t l = 0; l < lights.size(); ++l) {
            Ray r;
            r.tMax = 0.0f;
            r.direction = glm::vec3(0.0f);
            if ((out.size() % 7) != 3) {
                r.origin = geometry::OffsetRayOrigin(p, -eye.direction);
                const glm::vec3 toLight = lights[l] - r.origin;
                r.tMax = glm::length(toLight);
                r.direction = toLight / r.tMax;
            }
            out.push_back(r);
        }
    }
    return out;
}

inline std::vector<bool> Blocked(const scene::Scene& s, const LeafBatch& batch,
                                 const std::vector<Ray>& rays) {
    std::vector<Hit<float>> hits(rays.size());
    QueryHost(s, batch, rays, hits, /*anyHit=*/true);
    std::vector<bool> out;
    for (const auto& h : hits) out.push_back(h.Valid());
    return out;
}

inline std::vector<bool> BlockedBruteForce(const scene::Scene& s, const std::vector<Ray>& rays) {
    std::vector<bool> out;
    for (const Ray& r : rays) out.push_back(geometry::Occluded(s, ToGeometryRay(r)));
    return out;
}

inline void ExpectEveryRayOnce(const LeafBatch& batch, uint32_t nRays) {
    std::vector<int> seen(nRays, 0);
    for (const RcLeaf& leaf : batch.leaves) {
        for (uint32_t j = 0; j < leaf.rayCount; ++j) ++seen[batch.rayIndex[leaf.rayBegin + j]];
    }
    for (uint32_t id : batch.missed) ++seen[id];
    for (uint32_t i = 0; i < nRays; ++i) ASSERT_EQ(seen[i], 1) << "ray " << i;
    EXPECT_EQ(batch.nRays, nRays);
}

}  // namespace rayclass::classify
