// Stability where the methods fail: floating-point scale and self-intersection, grazing
// and degenerate triangles, watertightness of the triangle tests on a closed mesh, and the limits
// of ray classification. Each test asserts a measured bound against double precision or brute
// force, and prints what it measured (grep "[stability]") for docs/reliability.md.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "rayclass/classify/hierarchy.h"
#include "rayclass/classify/query.h"
#include "rayclass/geometry/intersect.h"
#include "rayclass/geometry/offset.h"

namespace rayclass {
namespace {

using geometry::Hit;
using geometry::TriangleTest;
using Rayf = geometry::Ray<float>;
using Rayd = geometry::Ray<double>;

scene::Triangle Tri(glm::vec3 a, glm::vec3 b, glm::vec3 c) {
    scene::Triangle t;
    t.p = {a, b, c};
    return t;
}

// A closed latitude-longitude sphere: single-vertex poles, every edge shared by two triangles.
// `jitter` moves each vertex radially by up to that fraction (the vertices stay shared).
std::vector<scene::Triangle> TessellatedSphere(glm::dvec3 center, double radius, int rings,
                                               int segments, double jitter, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> j(-jitter, jitter);
    std::vector<glm::vec3> v;
    const double pi = std::acos(-1.0);
    v.push_back(glm::vec3(center + glm::dvec3(0, radius * (1 + j(rng)), 0)));
    for (int r = 1; r < rings; ++r) {
        const double theta = pi * r / rings;
        for (int s = 0; s < segments; ++s) {
            const double phi = 2 * pi * s / segments;
            const glm::dvec3 dir(std::sin(theta) * std::cos(phi), std::cos(theta),
                                 std::sin(theta) * std::sin(phi));
            v.push_back(glm::vec3(center + radius * (1 + j(rng)) * dir));
        }
    }
    v.push_back(glm::vec3(center - glm::dvec3(0, radius * (1 + j(rng)), 0)));
    const auto at = [&](int r, int s) { return v[size_t(1 + (r - 1) * segments + s % segments)]; };
    std::vector<scene::Triangle> tris;
    for (int s = 0; s < segments; ++s) {
        tris.push_back(Tri(v.front(), at(1, s + 1), at(1, s)));
        tris.push_back(Tri(v.back(), at(rings - 1, s), at(rings - 1, s + 1)));
        for (int r = 1; r + 1 < rings; ++r) {
            tris.push_back(Tri(at(r, s), at(r, s + 1), at(r + 1, s + 1)));
            tris.push_back(Tri(at(r, s), at(r + 1, s + 1), at(r + 1, s)));
        }
    }
    return tris;
}

glm::dvec3 RandomUnit(std::mt19937& rng) {
    std::normal_distribution<double> n;
    for (;;) {
        const glm::dvec3 d(n(rng), n(rng), n(rng));
        if (glm::length(d) > 1e-3) return glm::normalize(d);
    }
}

// ---------------------------------------------------------------- floating-point scale

enum class Shape { kMesh, kSphere, kQuadric };
const char* Name(Shape s) {
    return s == Shape::kMesh ? "mesh" : s == Shape::kSphere ? "sphere" : "quadric";
}

// One convex object of size `scale` centred at (t, t/2, -t): a tessellated sphere, an analytic
// sphere, or a quadric cylinder along y clipped to its height.
scene::Scene ScaledObject(Shape shape, double t, double scale) {
    scene::Scene s;
    const glm::dvec3 c(t, t / 2, -t);
    if (shape == Shape::kMesh) {
        s.triangles = TessellatedSphere(c, scale, 12, 24, 0.0, 1);
    } else if (shape == Shape::kSphere) {
        s.spheres.push_back({glm::vec3(c), float(scale), 0, 0});
    } else {
        // (x - cx)^2 + (z - cz)^2 - r^2 = 0, coefficients rounded to float as the loader does.
        scene::Quadric q;
        q.c = {1,
               0,
               1,
               0,
               0,
               0,
               float(-2 * c.x),
               0,
               float(-2 * c.z),
               float(c.x * c.x + c.z * c.z - scale * scale)};
        q.boxMin = glm::vec3(c - glm::dvec3(scale, scale, scale));
        q.boxMax = glm::vec3(c + glm::dvec3(scale, scale, scale));
        s.quadrics.push_back(q);
    }
    return s;
}

glm::vec3 GeometricNormal(const scene::Scene& s, uint32_t prim, glm::vec3 p) {
    if (prim < s.SphereBase()) {
        const auto& t = s.triangles[prim];
        return glm::normalize(glm::cross(t.p[1] - t.p[0], t.p[2] - t.p[0]));
    }
    if (prim < s.QuadricBase()) {
        const auto& sp = s.spheres[prim - s.SphereBase()];
        return glm::vec3(glm::normalize(glm::dvec3(p) - glm::dvec3(sp.center)));
    }
    const auto& q = s.quadrics[prim - s.QuadricBase()];
    return glm::normalize(geometry::QuadricGradient(geometry::QuadricCoefficients<float>(q), p));
}

struct SelfHits {
    int primary = 0;          // eye rays that hit
    int outward = 0;          // re-hits of rays leaving outward from the hit (none possible)
    int inward = 0;           // re-hits closer than 1e-3 of the size on rays entering the object
    int outwardNoOffset = 0;  // the same without the origin offset: the failure it prevents
    int inwardNoOffset = 0;
    int referenceHits = 0;  // eye rays that hit in double precision
};

// Eye rays from a sphere of radius 3 * scale aimed at the object; from each hit a ray leaves
// outward (reflection: a convex object cannot be hit again) and one enters (refraction, for
// non-grazing hits: the far side is at least 0.2 * scale away), both from the offset origin.
SelfHits MeasureSelfHits(Shape shape, double t, double scale, int n) {
    const scene::Scene s = ScaledObject(shape, t, scale);
    const glm::dvec3 c(t, t / 2, -t);
    std::mt19937 rng(42);
    SelfHits out;
    for (int i = 0; i < n; ++i) {
        const glm::dvec3 from = c + 3.0 * scale * RandomUnit(rng);
        const glm::dvec3 to = c + 0.6 * scale * RandomUnit(rng) * glm::dvec3(1, 0.5, 1);
        const Rayf eye{glm::vec3(from), glm::vec3(glm::normalize(to - from))};
        const Rayd eyeD{glm::dvec3(eye.o), glm::dvec3(eye.d)};
        if (geometry::IntersectBruteForce(s, eyeD).Valid()) ++out.referenceHits;
        const Hit<float> hit = geometry::IntersectBruteForce(s, eye);
        if (!hit.Valid()) continue;
        ++out.primary;
        const glm::vec3 p = eye.o + hit.t * eye.d;
        glm::vec3 n = GeometricNormal(s, hit.prim, p);
        if (glm::dot(n, eye.d) > 0.0f) n = -n;  // towards the side the ray came from
        const float cosIn = -glm::dot(n, eye.d);
        const glm::vec3 reflected = eye.d + 2.0f * cosIn * n;
        const auto rehit = [&](glm::vec3 o, glm::vec3 d, double within) {
            const Hit<float> h = geometry::IntersectBruteForce(s, Rayf{o, d});
            return h.Valid() && double(h.t) < within;
        };
        const double inf = std::numeric_limits<double>::infinity();
        out.outward += rehit(geometry::OffsetRayOrigin(p, n), reflected, inf);
        out.outwardNoOffset += rehit(p, reflected, inf);
        if (cosIn > 0.1f) {
            out.inward += rehit(geometry::OffsetRayOrigin(p, -n), eye.d, 1e-3 * scale);
            out.inwardNoOffset += rehit(p, eye.d, 1e-3 * scale);
        }
    }
    return out;
}

TEST(Stability, SpawnedRaysNeverRehitTheirSurfaceAtAnyScale) {
    // Offsets of 0, +-1e6, 1e-6 and sizes 1e-4, 1, 1e4. A float keeps 24 bits: an object smaller
    // than 1000 ulps of its position is not representable (its vertices collapse onto a coarse
    // grid), so those combinations (1e6 with sizes 1e-4 and 1) are out of float's depth and
    // skipped.
    const int n = 1500;
    for (const double t : {0.0, 1e-6, 1e6, -1e6}) {
        for (const double scale : {1e-4, 1.0, 1e4}) {
            const double ulp =
                std::nextafter(float(std::fabs(t) + scale), INFINITY) - float(std::fabs(t) + scale);
            if (scale < 1000 * ulp) continue;
            for (const Shape shape : {Shape::kMesh, Shape::kSphere, Shape::kQuadric}) {
                const SelfHits h = MeasureSelfHits(shape, t, scale, n);
                std::printf(
                    "[stability] scale %-7s t=%-6g s=%-6g eye hits %4d (double %4d) "
                    "outward re-hits %d (no offset %d), inward %d (no offset %d)\n",
                    Name(shape), t, scale, h.primary, h.referenceHits, h.outward, h.outwardNoOffset,
                    h.inward, h.inwardNoOffset);
                // Quadrics far from the origin: the coefficients (J ~ t^2 = 1e12) lose the
                // shape's digits in float, the root's point is off the surface by more than the
                // offset, and a few reflected rays re-hit (measured 6 and 5 of ~1270 at +-1e6).
                // Bound asserted: 1% there, none elsewhere.
                const int allowed =
                    shape == Shape::kQuadric && std::fabs(t) >= 1e6 ? h.primary / 100 : 0;
                EXPECT_LE(h.outward, allowed) << Name(shape) << " t=" << t << " s=" << scale;
                EXPECT_EQ(h.inward, 0) << Name(shape) << " t=" << t << " s=" << scale;
                // Float finds the same eye hits as double up to rays that graze the silhouette.
                EXPECT_LE(std::abs(h.primary - h.referenceHits), n / 100)
                    << Name(shape) << " t=" << t << " s=" << scale;
            }
        }
    }
}

// ---------------------------------------------------------------- grazing and degenerate

TEST(Stability, RaysInATrianglesPlaneNeverHitIt) {
    const glm::vec3 a(0, 0, 0), b(1, 0, 0), c(0, 0, 1);
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> u(-2, 2);
    for (int i = 0; i < 2000; ++i) {
        const glm::vec3 o(u(rng), 0, u(rng));
        const glm::vec3 d(u(rng), 0, u(rng));
        for (const TriangleTest test : {TriangleTest::kMoller, TriangleTest::kWatertight}) {
            float t = -1, uu = -1, vv = -1;
            const Rayf r{o, d};
            const bool hit = test == TriangleTest::kMoller
                                 ? geometry::IntersectTriangle(r, a, b, c, t, uu, vv)
                                 : geometry::IntersectTriangleWatertight(r, a, b, c, t, uu, vv);
            EXPECT_FALSE(hit) << "in-plane ray " << i;
        }
    }
}

// Fraction of random rays through the box of `tri` whose float hit/miss differs from double.
struct DegenerateCounts {
    int hits = 0, disagreements = 0;
};
DegenerateCounts CountAgainstDouble(const std::array<glm::vec3, 3>& p, TriangleTest test, int n) {
    std::mt19937 rng(5);
    DegenerateCounts out;
    const glm::vec3 mid = (p[0] + p[1] + p[2]) / 3.0f;
    for (int i = 0; i < n; ++i) {
        const glm::dvec3 dir = RandomUnit(rng);
        const glm::vec3 o = mid - glm::vec3(2.0 * dir);
        const glm::vec3 d = glm::vec3(dir);
        float t, u, v;
        double td, ud, vd;
        const bool f =
            test == TriangleTest::kMoller
                ? geometry::IntersectTriangle(Rayf{o, d}, p[0], p[1], p[2], t, u, v)
                : geometry::IntersectTriangleWatertight(Rayf{o, d}, p[0], p[1], p[2], t, u, v);
        const Rayd rd{glm::dvec3(o), glm::dvec3(d)};
        const glm::dvec3 q0(p[0]), q1(p[1]), q2(p[2]);
        const bool dbl = geometry::IntersectTriangle(rd, q0, q1, q2, td, ud, vd) &&
                         glm::cross(q1 - q0, q2 - q0) != glm::dvec3(0.0);
        out.hits += f;
        out.disagreements += f != dbl;
    }
    return out;
}

TEST(Stability, ZeroAreaNeedleAndDuplicateTriangles) {
    const int n = 20000;
    for (const TriangleTest test : {TriangleTest::kMoller, TriangleTest::kWatertight}) {
        const char* name = test == TriangleTest::kMoller ? "moller" : "watertight";
        // Zero area: a point and three collinear points (exactly representable multiples): no
        // ray may hit them (a hit would have no normal).
        const auto point = CountAgainstDouble(
            {glm::vec3(1, 2, 3), glm::vec3(1, 2, 3), glm::vec3(1, 2, 3)}, test, n);
        const auto line = CountAgainstDouble(
            {glm::vec3(0, 0, 0), glm::vec3(1, 2, 3), glm::vec3(2, 4, 6)}, test, n);
        const auto line2 = CountAgainstDouble(
            {glm::vec3(0.1f, 0.2f, 0.3f), glm::vec3(0.2f, 0.4f, 0.6f), glm::vec3(0.4f, 0.8f, 1.2f)},
            test, n);
        // A needle 1e-6 wide and 1 long: float and double may only disagree on rays within
        // rounding distance of its edges.
        const auto needle = CountAgainstDouble(
            {glm::vec3(0, 0, 0), glm::vec3(1, 0, 0), glm::vec3(0.5f, 1e-6f, 0)}, test, n);
        std::printf(
            "[stability] degenerate %-10s zero-area hits: point %d, exact line %d, "
            "rounded line %d (%d disagree with double); needle hits %d, float/double "
            "disagreements %d of %d\n",
            name, point.hits, line.hits, line2.hits, line2.disagreements, needle.hits,
            needle.disagreements, n);
        // Measured (the printed line): a point is never hit; a triangle whose edges are exact
        // multiples is hit by 2.4% (Moeller) and 34% (watertight) of rays through it, by
        // rounding. The loader therefore collapses float-zero-area triangles onto a point
        // (HostileScene.ZeroAreaTrianglesAreCollapsedSoNoRayHitsThem).
        EXPECT_EQ(point.hits, 0) << name;
        EXPECT_LE(line.hits, n * 2 / 5) << name;
        EXPECT_LE(line2.hits, n * 2 / 5) << name;  // 0.1f, 0.2f, 0.4f: exact multiples too
        EXPECT_LE(needle.disagreements, 2) << name;
    }
    // Duplicates: the lower id wins every tie, in either order of testing.
    scene::Scene s;
    s.triangles = {Tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}), Tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}),
                   Tri({1, 0, 0}, {0, 1, 0}, {0, 0, 0})};
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(0, 0.5f);
    for (int i = 0; i < 1000; ++i) {
        const Rayf r{glm::vec3(u(rng), u(rng), 1), glm::vec3(0, 0, -1)};
        for (const TriangleTest test : {TriangleTest::kMoller, TriangleTest::kWatertight}) {
            const Hit<float> h = geometry::IntersectBruteForce(s, r, test);
            ASSERT_TRUE(h.Valid());
            EXPECT_EQ(h.prim, 0u);
        }
    }
}

// ---------------------------------------------------------------- watertightness

// Rays from random points inside a closed, perturbed tessellated sphere aimed exactly at its
// vertices and edge midpoints: each must hit the mesh.
int WatertightMisses(TriangleTest test, double offset, int* rays) {
    const glm::dvec3 c(offset, offset, offset);
    scene::Scene s;
    s.triangles = TessellatedSphere(c, 1.0, 24, 48, 0.05, 17);
    std::mt19937 rng(23);
    int misses = 0;
    *rays = 0;
    for (const scene::Triangle& t : s.triangles) {
        const glm::vec3 targets[] = {t.p[0], 0.5f * (t.p[0] + t.p[1]), 0.5f * (t.p[1] + t.p[2])};
        for (const glm::vec3& target : targets) {
            for (int k = 0; k < 4; ++k) {
                // From inside the closed mesh every ray must leave through it, whatever the
                // rounding of its direction (a target on the silhouette seen from outside could
                // be missed legitimately).
                const glm::vec3 from = glm::vec3(c + 0.5 * RandomUnit(rng));
                const Rayf r{from, target - from};
                ++*rays;
                misses += !geometry::IntersectBruteForce(s, r, test).Valid();
            }
        }
    }
    return misses;
}

TEST(Stability, WatertightTestNeverLetsRaysThroughSharedEdgesAndVertices) {
    int total = 0, mollerMisses = 0;
    for (const double offset : {0.0, 3.0, 100.0}) {
        int rays = 0;
        const int moller = WatertightMisses(TriangleTest::kMoller, offset, &rays);
        const int watertight = WatertightMisses(TriangleTest::kWatertight, offset, &rays);
        std::printf(
            "[stability] watertight centre %-5g rays %d: moller misses %d, watertight "
            "misses %d\n",
            offset, rays, moller, watertight);
        EXPECT_EQ(watertight, 0) << "centre " << offset;
        total += rays;
        mollerMisses += moller;
    }
    // The difference the option makes: Moeller-Trumbore lets some of these rays through.
    EXPECT_GT(mollerMisses, 0) << "of " << total;
}

// ---------------------------------------------------------------- ray classification limits

// Primitives scattered over [-10, 10]^3: triangles with edges up to about 1.2 * size, spheres of
// radius 0.05 * size to 0.8 * size.
scene::Scene RandomScene(int nTriangles, int nSpheres, uint32_t seed, float size = 1.0f) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-10, 10), small(-0.6f * size, 0.6f * size),
        r(0.05f * size, 0.8f * size);
    scene::Scene s;
    for (int i = 0; i < nTriangles; ++i) {
        const glm::vec3 a(u(rng), u(rng), u(rng));
        s.triangles.push_back(Tri(a, a + glm::vec3(small(rng), small(rng), small(rng)),
                                  a + glm::vec3(small(rng), small(rng), small(rng))));
    }
    for (int i = 0; i < nSpheres; ++i) {
        s.spheres.push_back({glm::vec3(u(rng), u(rng), u(rng)), r(rng), 0, 0});
    }
    return s;
}

std::vector<classify::Ray> RandomRays(int n, uint32_t seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> u(-12, 12);
    std::vector<classify::Ray> rays(static_cast<size_t>(n));
    for (auto& r : rays) {
        r.origin = glm::vec3(u(rng), u(rng), u(rng));
        r.direction = glm::vec3(RandomUnit(rng));
    }
    return rays;
}

// Every ray's hit through the hierarchy equals brute force exactly (t and primitive).
int Mismatches(const scene::Scene& s, const classify::Params& p,
               const std::vector<classify::Ray>& rays, size_t* memory, size_t* maxList) {
    classify::Hierarchy h(s, p);
    const classify::LeafBatch batch = h.Classify(rays);
    std::vector<Hit<float>> hits(rays.size());
    classify::QueryHost(s, batch, rays, hits);
    int bad = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        const Hit<float> truth = geometry::IntersectBruteForce(s, classify::ToGeometryRay(rays[i]));
        bad += truth.prim != hits[i].prim || (truth.Valid() && truth.t != hits[i].t);
    }
    *memory = h.MemoryBytes() + batch.leaves.capacity() * sizeof(RcLeaf) +
              batch.rayIndex.capacity() * 4 + batch.candidates.capacity() * sizeof(RcCandidate);
    *maxList = 0;
    for (const RcLeaf& leaf : batch.leaves) *maxList = std::max<size_t>(*maxList, leaf.candCount);
    return bad;
}

TEST(Stability, ClassificationStaysExactForIncoherentRaysAndWholeSceneLeaves) {
    const scene::Scene s = RandomScene(1500, 200, 31);
    const uint32_t nPrims = s.PrimitiveCount();
    // Very incoherent: random origins all over the box, random directions.
    const std::vector<classify::Ray> rays = RandomRays(100000, 37);
    size_t memory = 0, maxList = 0;
    EXPECT_EQ(Mismatches(s, classify::Params::ForScene(s), rays, &memory, &maxList), 0);
    std::printf(
        "[stability] classify incoherent: %zu rays, %u prims, memory %zu bytes "
        "(%.1f per ray), longest list %zu\n",
        rays.size(), nPrims, memory, double(memory) / double(rays.size()), maxList);
    // Bound: the rays' own index and the candidate lists dominate; 1 KiB per ray is far above
    // the measured figure and far below a per-ray copy of the scene (nPrims * 8 bytes = 13.6 KB).
    EXPECT_LE(memory, rays.size() * 1024);

    // A leaf whose list is the whole scene: a cost function that never splits.
    classify::Params never = classify::Params::ForScene(s);
    never.minRays = 1u << 30;
    const std::vector<classify::Ray> few(rays.begin(), rays.begin() + 20000);
    EXPECT_EQ(Mismatches(s, never, few, &memory, &maxList), 0);
    std::printf("[stability] classify whole-scene leaves: longest list %zu of %u, memory %zu\n",
                maxList, nPrims, memory);
    EXPECT_EQ(maxList, nPrims);
    EXPECT_LE(memory, few.size() * 1024 + size_t(nPrims) * 6 * 64);
}

// Peak resident memory of this process so far (CTest runs each test in its own process).
size_t PeakRssBytes() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return size_t(usage.ru_maxrss) * 1024;
}

#if defined(__SANITIZE_ADDRESS__)  // GCC, which scripts/sanitize uses
#define RC_UNDER_ASAN 1
#elif defined(__has_feature)  // clang
#if __has_feature(address_sanitizer)
#define RC_UNDER_ASAN 1
#endif
#endif

// 10^7 incoherent rays in one generation, through a scene small enough (32 primitives) that brute
// force can check every ray on the host: the hierarchy's scratch then grows with the rays alone.
// The primitives are large, so that many rays hit and the lists are long. Then the same rays
// through leaves whose lists are the whole scene (a cost function that never splits). The
// suite's longest test.
TEST(Stability, ClassificationStaysExactAndBoundedForTenMillionIncoherentRays) {
#ifdef RC_UNDER_ASAN
    // Under scripts/sanitize it runs several times slower and needs more memory, and would take
    // most of the sanitizer run; the 10^5-ray test above runs the same code under ASan.
    GTEST_SKIP() << "10^7 rays take 2 minutes under AddressSanitizer";
#endif
    using Clock = std::chrono::steady_clock;
    const auto seconds = [](Clock::time_point a, Clock::time_point b) {
        return std::chrono::duration<double>(b - a).count();
    };
    const scene::Scene s = RandomScene(24, 8, 41, 8.0f);
    const uint32_t nPrims = s.PrimitiveCount();
    auto t = Clock::now();
    const std::vector<classify::Ray> rays = RandomRays(10'000'000, 43);
    std::printf("[stability] classify 1e7: rays made in %.1f s\n", seconds(t, Clock::now()));

    // Classifies and queries every ray; the hierarchy is gone when it returns.
    const auto classifyAndQuery = [&](const classify::Params& params, size_t* memory,
                                      size_t* maxList) {
        const auto t0 = Clock::now();
        classify::Hierarchy h(s, params);
        const classify::LeafBatch batch = h.Classify(rays);
        const auto t1 = Clock::now();
        // Bytes the classification holds: nodes, face lists, reusable ray scratch, the leaves.
        *memory = h.MemoryBytes() + batch.leaves.capacity() * sizeof(RcLeaf) +
                  batch.rayIndex.capacity() * 4 + batch.missed.capacity() * 4 +
                  batch.candidates.capacity() * sizeof(RcCandidate);
        *maxList = 0;
        for (const RcLeaf& leaf : batch.leaves) {
            *maxList = std::max<size_t>(*maxList, leaf.candCount);
        }
        std::vector<Hit<float>> hits(rays.size());
        classify::QueryHost(s, batch, rays, hits);
        std::printf(
            "[stability] classify 1e7: %zu leaves, longest list %zu of %u, memory %zu "
            "bytes (%.1f per ray); classify %.1f s, query %.1f s\n",
            batch.leaves.size(), *maxList, nPrims, *memory, double(*memory) / double(rays.size()),
            seconds(t0, t1), seconds(t1, Clock::now()));
        return hits;
    };

    size_t memory = 0, maxList = 0;
    const std::vector<Hit<float>> hits =
        classifyAndQuery(classify::Params::ForScene(s), &memory, &maxList);
    t = Clock::now();
    size_t bad = 0, hitCount = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        const Hit<float> truth = geometry::IntersectBruteForce(s, classify::ToGeometryRay(rays[i]));
        bad += truth.prim != hits[i].prim || (truth.Valid() && truth.t != hits[i].t);
        hitCount += truth.Valid();
    }
    std::printf(
        "[stability] classify 1e7: %zu rays, %zu hit, %zu differ from brute force (%.1f "
        "s)\n",
        rays.size(), hitCount, bad, seconds(t, Clock::now()));
    EXPECT_EQ(bad, 0u) << "of " << rays.size();
    EXPECT_GT(hitCount, rays.size() / 5) << "the rays should hit the scene often";
    // Bound: per ray, two ping-pong buffers of six coordinates and an id (56 bytes), a
    // destination (4), the leaves' ids at their buffer positions (4) and the leaves' ray index
    // (4) dominate. 80 bytes leaves a margin over the figure printed above and fails if anything
    // else starts to grow per ray.
    EXPECT_LE(memory, rays.size() * 80);

    classify::Params never = classify::Params::ForScene(s);
    never.minRays = 1u << 30;
    const std::vector<Hit<float>> whole = classifyAndQuery(never, &memory, &maxList);
    EXPECT_EQ(maxList, nPrims);
    EXPECT_LE(memory, rays.size() * 80);
    bad = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
        bad += whole[i].prim != hits[i].prim || (hits[i].Valid() && whole[i].t != hits[i].t);
    }
    EXPECT_EQ(bad, 0u) << "whole-scene leaves differ from the checked answers";

    // Rays 32 bytes, two hit arrays of 16 bytes and the classification per ray, with a margin
    // over the peak printed here.
    std::printf("[stability] classify 1e7: peak RSS %zu MiB\n", PeakRssBytes() >> 20);
    EXPECT_LE(PeakRssBytes(), size_t(3) << 29) << "1.5 GiB";
}

}  // namespace
}  // namespace rayclass
