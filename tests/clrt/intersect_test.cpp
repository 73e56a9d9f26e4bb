// The device's intersection routines (cl/intersect.cl, called through cl/intersect_probe.cl) agree
// with their host float twins (include/rayclass/geometry/intersect.h) on a grid of rays that
// includes the hard cases: grazing and tangent rays, rays through triangle edges and vertices and
// through the rims where a quadric meets its clip box, rays along a quadric's axis (the linear
// branch), rays lying in a hyperboloid's rulings, rays starting on the surface. On the rays whose
// answer is well-conditioned, float agrees with the double-precision routines. The device's
// rc_offset_ray_origin equals geometry::OffsetRayOrigin<float> bit for bit.
#include "rayclass/geometry/intersect.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <glm/glm.hpp>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "clrt/device.h"
#include "rayclass/geometry/offset.h"
#include "rc_types.h"

namespace rayclass::clrt {
namespace {

using testing::Download;
using testing::kProbeOptions;
using testing::TestContext;
using testing::Upload;

constexpr float kInf = std::numeric_limits<float>::infinity();

rc_float4 F4(const glm::vec3& v, float w = 0.0f) { return {v.x, v.y, v.z, w}; }
glm::vec3 V3(const rc_float4& v) { return {v.x, v.y, v.z}; }

// Distance in units in the last place between two finite floats of any signs.
int64_t UlpDistance(float a, float b) {
    auto key = [](float f) {
        const int32_t i = std::bit_cast<int32_t>(f);
        return i < 0 ? int64_t(std::numeric_limits<int32_t>::min()) - i : int64_t(i);
    };
    return std::abs(key(a) - key(b));
}

// ---- The primitives, each with what the ray generator needs to find its hard cases. ----

struct Shape {
    std::string name;
    glm::dvec3 lo, hi;  // bounds of the primitive: the targets' grid spans them
    // A point on the surface and its normal there (nullptr: no sampler, only grid rays).
    std::function<void(std::mt19937&, glm::dvec3&, glm::dvec3&)> surface;
    std::vector<glm::dvec3> boundary;  // vertices, points on edges, points on clip-box rims
    std::vector<glm::dvec3> lines;     // pairs (point, direction) of lines lying in the surface
};

Shape MakeShape(std::string name, const glm::dvec3& lo, const glm::dvec3& hi) {
    Shape s;
    s.name = std::move(name);
    s.lo = lo;
    s.hi = hi;
    return s;
}

struct Primitives {
    std::vector<RcTriangle> triangles;
    std::vector<RcSphere> spheres;
    std::vector<RcQuadric> quadrics;
    std::vector<Shape> shapes;  // triangles, then spheres, then quadrics: the ids' order

    uint32_t Count() const { return uint32_t(triangles.size() + spheres.size() + quadrics.size()); }
};

RcQuadric MakeQuadric(const std::array<float, 10>& c, glm::vec3 lo, glm::vec3 hi) {
    RcQuadric q{};
    q.c0 = {c[0], c[1], c[2], c[3]};
    q.c1 = {c[4], c[5], c[6], c[7]};
    q.c2 = {c[8], c[9], 0.0f, 0.0f};
    q.boxMin = F4(lo);
    q.boxMax = F4(hi);
    return q;
}

const double kPi = 3.14159265358979323846;

Primitives MakePrimitives() {
    Primitives p;
    {
        // A triangle in a plane that no axis is parallel to.
        const glm::dvec3 a(-1.0, -0.5, 0.3), b(1.25, -0.75, -0.2), c(0.125, 1.1, 0.4);
        p.triangles.push_back({F4(a), F4(b), F4(c)});
        const glm::dvec3 fa{glm::vec3(a)}, fb{glm::vec3(b)}, fc{glm::vec3(c)};
        Shape s =
            MakeShape("triangle", glm::min(fa, glm::min(fb, fc)), glm::max(fa, glm::max(fb, fc)));
        const glm::dvec3 n = glm::normalize(glm::cross(fb - fa, fc - fa));
        s.surface = [=](std::mt19937& rng, glm::dvec3& point, glm::dvec3& normal) {
            std::uniform_real_distribution<double> u01(0.0, 1.0);
            double u = u01(rng), v = u01(rng);
            if (u + v > 1.0) u = 1.0 - u, v = 1.0 - v;
            point = fa + u * (fb - fa) + v * (fc - fa);
            normal = n;
        };
        s.boundary = {fa, fb, fc};
        for (double f : {0.125, 0.5, 0.75}) {
            s.boundary.push_back(fa + f * (fb - fa));
            s.boundary.push_back(fb + f * (fc - fb));
            s.boundary.push_back(fc + f * (fa - fc));
        }
        // The edges' lines lie in the triangle's plane.
        s.lines = {fa, fb - fa, fb, fc - fb, fc, fa - fc};
        p.shapes.push_back(s);
    }
    {
        const glm::vec3 center(0.3f, -0.2f, 0.5f);
        const float radius = 1.25f;
        p.spheres.push_back({F4(center, radius), 0, 0, 0, 0});
        const glm::dvec3 c(center);
        const double r = radius;
        Shape s = MakeShape("sphere", c - r, c + r);
        s.surface = [=](std::mt19937& rng, glm::dvec3& point, glm::dvec3& normal) {
            std::normal_distribution<double> g;
            normal = glm::normalize(glm::dvec3(g(rng), g(rng), g(rng)));
            point = c + r * normal;
        };
        p.shapes.push_back(s);
    }
    {
        // Cylinder (x - cx)^2 + (z - cz)^2 = r^2 with its axis along y, clipped to y in [-1, 1].
        const double cx = 0.25, cz = -0.5, r = 0.75;
        p.quadrics.push_back(MakeQuadric(
            {1, 0, 1, 0, 0, 0, float(-2 * cx), 0, float(-2 * cz), float(cx * cx + cz * cz - r * r)},
            glm::vec3(cx - r, -1, cz - r), glm::vec3(cx + r, 1, cz + r)));
        Shape s = MakeShape("cylinder", {cx - r, -1, cz - r}, {cx + r, 1, cz + r});
        s.surface = [=](std::mt19937& rng, glm::dvec3& point, glm::dvec3& normal) {
            std::uniform_real_distribution<double> angle(0, 2 * kPi), height(-1, 1);
            const double a = angle(rng);
            normal = {std::cos(a), 0, std::sin(a)};
            point = glm::dvec3(cx, height(rng), cz) + r * normal;
        };
        for (int i = 0; i < 8; ++i) {
            const double a = 2 * kPi * i / 8;
            for (double y : {-1.0, 1.0}) {
                s.boundary.push_back({cx + r * std::cos(a), y, cz + r * std::sin(a)});
            }
            // Lines along the axis lie in the surface: the a = 0, b = 0 case.
            s.lines.push_back({cx + r * std::cos(a), -2, cz + r * std::sin(a)});
            s.lines.push_back({0, 1, 0});
        }
        p.shapes.push_back(s);
    }
    {
        // Hyperboloid of one sheet x^2 + z^2 - y^2 = k, clipped to y in [-1, 1].
        const double k = 0.5, s0 = std::sqrt(k), rim = std::sqrt(k + 1);
        p.quadrics.push_back(MakeQuadric({1, -1, 1, 0, 0, 0, 0, 0, 0, float(-k)},
                                         glm::vec3(-2, -1, -2), glm::vec3(2, 1, 2)));
        Shape s = MakeShape("hyperboloid", {-rim, -1, -rim}, {rim, 1, rim});
        s.surface = [=](std::mt19937& rng, glm::dvec3& point, glm::dvec3& normal) {
            std::uniform_real_distribution<double> angle(0, 2 * kPi), height(-1, 1);
            const double a = angle(rng), y = height(rng), radius = std::sqrt(k + y * y);
            point = {radius * std::cos(a), y, radius * std::sin(a)};
            normal = glm::normalize(glm::dvec3(point.x, -y, point.z));
        };
        for (int i = 0; i < 8; ++i) {
            const double a = 2 * kPi * i / 8;
            for (double y : {-1.0, 1.0}) {
                s.boundary.push_back({rim * std::cos(a), y, rim * std::sin(a)});
            }
            // Its two families of rulings: (s0 cos a - l sin a, +-l, s0 sin a + l cos a).
            for (double sign : {-1.0, 1.0}) {
                s.lines.push_back({s0 * std::cos(a), 0, s0 * std::sin(a)});
                s.lines.push_back({-std::sin(a), sign, std::cos(a)});
            }
        }
        p.shapes.push_back(s);
    }
    {
        // Paraboloid y = x^2 + z^2, clipped to y <= 0.75.
        const double top = 0.75, rim = std::sqrt(top);
        p.quadrics.push_back(MakeQuadric({1, 0, 1, 0, 0, 0, 0, -1, 0, 0}, glm::vec3(-1, -1, -1),
                                         glm::vec3(1, float(top), 1)));
        Shape s = MakeShape("paraboloid", {-rim, 0, -rim}, {rim, top, rim});
        s.surface = [=](std::mt19937& rng, glm::dvec3& point, glm::dvec3& normal) {
            std::uniform_real_distribution<double> angle(0, 2 * kPi), radius(0, rim);
            const double a = angle(rng), r = radius(rng);
            point = {r * std::cos(a), r * r, r * std::sin(a)};
            normal = glm::normalize(glm::dvec3(2 * point.x, -1, 2 * point.z));
        };
        s.boundary.push_back({0, 0, 0});  // the apex
        for (int i = 0; i < 8; ++i) {
            const double a = 2 * kPi * i / 8;
            s.boundary.push_back({rim * std::cos(a), top, rim * std::sin(a)});
            // Lines parallel to the axis cross it once: the a = 0, b != 0 (linear) branch.
            s.lines.push_back({0.5 * rim * std::cos(a), -1, 0.5 * rim * std::sin(a)});
            s.lines.push_back({0, 1, 0});
        }
        p.shapes.push_back(s);
    }
    {
        // A general quadric using all ten coefficients (a one-sheet hyperboloid, tilted and moved).
        p.quadrics.push_back(
            MakeQuadric({1.0f, -0.8f, 1.2f, 0.3f, 0.5f, -0.2f, 0.1f, -0.2f, 0.05f, -0.6f},
                        glm::vec3(-1.5f, -1.0f, -1.25f), glm::vec3(1.5f, 1.0f, 1.25f)));
        Shape s = MakeShape("general quadric", {-1.5, -1.0, -1.25}, {1.5, 1.0, 1.25});
        p.shapes.push_back(s);
    }
    return p;
}

// ---- Rays ----

struct Rays {
    std::vector<RcRay> rays;
    std::vector<std::string> kinds;  // what each ray is for, for failure messages

    void Add(const std::string& kind, const glm::dvec3& origin, const glm::dvec3& direction,
             float tmin = 0.0f, float tmax = kInf) {
        const glm::vec3 d = glm::normalize(glm::vec3(direction));
        if (!std::isfinite(d.x) || glm::length(direction) == 0.0) return;
        RcRay r{};
        r.origin = F4(glm::vec3(origin), tmin);
        r.direction = F4(d, tmax);
        rays.push_back(r);
        kinds.push_back(kind);
    }
};

glm::dvec3 RandomUnit(std::mt19937& rng) {
    std::normal_distribution<double> g;
    return glm::normalize(glm::dvec3(g(rng), g(rng), g(rng)));
}

// A unit vector perpendicular to n.
glm::dvec3 Perpendicular(const glm::dvec3& n, std::mt19937& rng) {
    for (;;) {
        const glm::dvec3 p = glm::cross(n, RandomUnit(rng));
        if (glm::length(p) > 0.1) return glm::normalize(p);
    }
}

Rays MakeRays(const Primitives& prims) {
    Rays out;
    std::mt19937 rng(20240611);
    // Origins: a 4x4x4 grid over [-3, 3]^3 (some inside the primitives, some in their planes).
    std::vector<glm::dvec3> origins;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j)
            for (int k = 0; k < 4; ++k) origins.push_back(glm::dvec3(i, j, k) * 2.0 - 3.0);
    for (const Shape& s : prims.shapes) {
        // Targets: a 5x5x5 grid over the primitive's bounds (its corners touch box rims and
        // triangle vertices), then the primitive's boundary points.
        std::vector<glm::dvec3> targets;
        for (int i = 0; i < 5; ++i)
            for (int j = 0; j < 5; ++j)
                for (int k = 0; k < 5; ++k)
                    targets.push_back(s.lo + (s.hi - s.lo) * glm::dvec3(i, j, k) / 4.0);
        const size_t nGrid = targets.size();
        targets.insert(targets.end(), s.boundary.begin(), s.boundary.end());
        for (const auto& o : origins) {
            for (size_t t = 0; t < targets.size(); ++t) {
                out.Add(s.name + (t < nGrid ? " grid" : " boundary"), o, targets[t] - o);
            }
        }
        // Boundary targets again with tmax at the target: a hit right at tmax.
        for (const auto& o : origins) {
            for (const auto& b : s.boundary) {
                out.Add(s.name + " boundary at tmax", o, b - o, 0.0f,
                        float(glm::length(glm::dvec3(glm::vec3(b)) - glm::dvec3(glm::vec3(o)))));
            }
        }
        // Lines lying in the surface, from outside the primitive and from on it.
        for (size_t i = 0; i + 1 < s.lines.size(); i += 2) {
            const glm::dvec3 point = s.lines[i], dir = glm::normalize(s.lines[i + 1]);
            for (double back : {0.0, 0.5, 3.0}) {
                out.Add(s.name + " in-surface line", point - back * dir, dir);
                out.Add(s.name + " in-surface line", point + back * dir, -dir);
            }
        }
        if (!s.surface) continue;
        for (int i = 0; i < 200; ++i) {
            glm::dvec3 point, normal;
            s.surface(rng, point, normal);
            // Tangent at the point, arriving from 2 units away (in the plane, for the triangle).
            const glm::dvec3 tangent = Perpendicular(normal, rng);
            out.Add(s.name + " tangent", point - 2.0 * tangent, tangent);
            // Nearly tangent: a tilt of 1e-4 towards either side.
            out.Add(s.name + " near-tangent", point - 2.0 * tangent, tangent + 1e-4 * normal);
            out.Add(s.name + " near-tangent", point - 2.0 * tangent, tangent - 1e-4 * normal);
            // Starting on the surface (rounded to float), into either side and along it.
            const glm::dvec3 d = RandomUnit(rng);
            out.Add(s.name + " from surface", point, d);
            out.Add(s.name + " from surface", point, -d);
            out.Add(s.name + " from surface", point, tangent);
            // Starting on the surface, perpendicular, either way.
            out.Add(s.name + " from surface", point, normal);
            out.Add(s.name + " from surface", point, -normal);
        }
    }
    return out;
}

// ---- Host evaluation ----

struct Result {
    bool hit = false;
    float t = 0, u = 0, v = 0;
};

template <typename T>
bool HostIntersect(const Primitives& p, uint32_t id, const geometry::Ray<T>& ray, T& t, T& u,
                   T& v) {
    using V = glm::vec<3, T>;
    const auto nT = uint32_t(p.triangles.size()), nS = uint32_t(p.spheres.size());
    if (id < nT) {
        const RcTriangle& tri = p.triangles[id];
        return geometry::IntersectTriangle(ray, V(V3(tri.v0)), V(V3(tri.v1)), V(V3(tri.v2)), t, u,
                                           v);
    }
    if (id < nT + nS) {
        const rc_float4 cr = p.spheres[id - nT].centerRadius;
        return geometry::IntersectSphere(ray, V(V3(cr)), T(cr.w), t);
    }
    const RcQuadric& q = p.quadrics[id - nT - nS];
    const std::array<T, 10> c = {q.c0.x, q.c0.y, q.c0.z, q.c0.w, q.c1.x,
                                 q.c1.y, q.c1.z, q.c1.w, q.c2.x, q.c2.y};
    return geometry::IntersectQuadric(ray, c, V(V3(q.boxMin)), V(V3(q.boxMax)), t);
}

template <typename T>
geometry::Ray<T> HostRay(const RcRay& r) {
    using V = glm::vec<3, T>;
    return {V(V3(r.origin)), V(V3(r.direction)), T(r.origin.w), T(r.direction.w)};
}

// ---- Device evaluation, once per test binary ----

const cl::Program& ProbeProgram() {
    static const cl::Program program =
        TestContext().BuildProgram({"intersect_probe.cl"}, kProbeOptions);
    return program;
}

struct DeviceRun {
    Primitives prims = MakePrimitives();
    Rays rays = MakeRays(prims);
    std::vector<Result> device;  // item = ray * nPrims + prim
};

const DeviceRun& ProbeRun() {
    static const DeviceRun run = [] {
        DeviceRun r;
        auto& ctx = TestContext();
        cl::Kernel kernel(ProbeProgram(), "rc_probe_intersect");
        const uint32_t nRays = uint32_t(r.rays.rays.size()), nPrims = r.prims.Count();
        const size_t items = size_t(nRays) * nPrims;
        const cl::Buffer rays = Upload(r.rays.rays), tris = Upload(r.prims.triangles),
                         spheres = Upload(r.prims.spheres), quads = Upload(r.prims.quadrics);
        cl::Buffer out(ctx.context(), CL_MEM_WRITE_ONLY, items * sizeof(cl_uint4));
        kernel.setArg(0, rays);
        kernel.setArg(1, nRays);
        kernel.setArg(2, tris);
        kernel.setArg(3, uint32_t(r.prims.triangles.size()));
        kernel.setArg(4, spheres);
        kernel.setArg(5, uint32_t(r.prims.spheres.size()));
        kernel.setArg(6, quads);
        kernel.setArg(7, uint32_t(r.prims.quadrics.size()));
        kernel.setArg(8, out);
        ctx.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(items));
        for (const cl_uint4& o : Download<cl_uint4>(out, items)) {
            r.device.push_back({o.s[0] != 0, std::bit_cast<float>(o.s[1]),
                                std::bit_cast<float>(o.s[2]), std::bit_cast<float>(o.s[3])});
        }
        return r;
    }();
    return run;
}

std::string Describe(const DeviceRun& run, size_t ray, uint32_t prim) {
    const RcRay& r = run.rays.rays[ray];
    std::ostringstream s;
    s.precision(9);
    s << run.rays.kinds[ray] << " ray " << ray << " vs " << run.prims.shapes[prim].name << ": o=("
      << r.origin.x << ", " << r.origin.y << ", " << r.origin.z << ") d=(" << r.direction.x << ", "
      << r.direction.y << ", " << r.direction.z << ") tmin=" << r.origin.w
      << " tmax=" << r.direction.w;
    return s.str();
}

// Tolerance of device t (and u, v) against host t. Both evaluate the same formulas in the same
// order without contraction, but OpenCL C lets sqrt be off by up to 3 ulp and division by 2.5 ulp
// (unless built with -cl-fp32-correctly-rounded-divide-sqrt, which the renderer does not use) and
// leaves the rounding of dot() and cross() to the implementation; an ulp or two of either moves t
// by about as much, so 8 ulps leaves room for them. (PoCL's CPU device matches the host bit for
// bit on every hit of this grid.) Hit flags must match exactly all the same: a device whose
// rounding flips a grazing ray would disagree with the host-side queries.
constexpr int64_t kTUlps = 8;

TEST(IntersectDevice, HitFlagsAndDistancesMatchTheHostFloatRoutines) {
    const DeviceRun& run = ProbeRun();
    const uint32_t nPrims = run.prims.Count();
    size_t hits = 0, mismatches = 0;
    std::map<std::string, size_t> hitsByKind;
    for (size_t ray = 0; ray < run.rays.rays.size(); ++ray) {
        const auto hostRay = HostRay<float>(run.rays.rays[ray]);
        for (uint32_t prim = 0; prim < nPrims; ++prim) {
            const Result& dev = run.device[ray * nPrims + prim];
            Result host;
            host.hit = HostIntersect(run.prims, prim, hostRay, host.t, host.u, host.v);
            if (host.hit != dev.hit) {
                if (++mismatches <= 10) {
                    ADD_FAILURE() << Describe(run, ray, prim) << ": host hit " << host.hit
                                  << " (t=" << host.t << "), device hit " << dev.hit
                                  << " (t=" << dev.t << ")";
                }
                continue;
            }
            if (!host.hit) continue;
            ++hits;
            ++hitsByKind[run.rays.kinds[ray]];
            if (UlpDistance(host.t, dev.t) > kTUlps) {
                if (++mismatches <= 10) {
                    ADD_FAILURE() << Describe(run, ray, prim) << ": t host " << host.t << " device "
                                  << dev.t << " (" << UlpDistance(host.t, dev.t) << " ulps)";
                }
            }
            if (prim < run.prims.triangles.size()) {
                // u and v come from the same dot products and reciprocal as t.
                if (UlpDistance(host.u, dev.u) > kTUlps || UlpDistance(host.v, dev.v) > kTUlps) {
                    if (++mismatches <= 10) {
                        ADD_FAILURE()
                            << Describe(run, ray, prim) << ": (u, v) host (" << host.u << ", "
                            << host.v << ") device (" << dev.u << ", " << dev.v << ")";
                    }
                }
            }
        }
    }
    EXPECT_EQ(mismatches, 0u);
    // The grid must exercise the routines: thousands of hits, and hits among the hard cases.
    EXPECT_GT(hits, 10000u);
    for (const char* kind :
         {"triangle boundary", "triangle from surface", "sphere tangent", "sphere near-tangent",
          "sphere from surface", "cylinder boundary", "hyperboloid boundary",
          "paraboloid in-surface line", "paraboloid from surface"}) {
        EXPECT_GT(hitsByKind[kind], 0u) << kind;
    }
}

// Distance in double of the ray's decision from a triangle's edges and from tmin: the smallest
// barycentric coordinate magnitude of the point where the ray meets the triangle's plane, and the
// distance of that point's t from tmin. Edges and vertices are where the answer flips.
bool AwayFromTriangleEdges(const RcTriangle& tri, const geometry::Ray<double>& ray) {
    constexpr double kMargin = 1e-4;
    const glm::dvec3 p0(V3(tri.v0)), e1 = glm::dvec3(V3(tri.v1)) - p0,
                                     e2 = glm::dvec3(V3(tri.v2)) - p0;
    const glm::dvec3 pv = glm::cross(ray.d, e2);
    const double det = glm::dot(e1, pv);
    // Nearly in the triangle's plane (angle below about 0.06 degrees).
    if (std::abs(det) <= 1e-3 * glm::length(glm::cross(e1, e2)) * glm::length(ray.d)) return false;
    const glm::dvec3 tv = ray.o - p0, qv = glm::cross(tv, e1);
    const double u = glm::dot(tv, pv) / det, v = glm::dot(ray.d, qv) / det;
    const double t = glm::dot(e2, qv) / det;
    return std::min({std::abs(u), std::abs(v), std::abs(1 - u - v)}) > kMargin &&
           std::abs(t - ray.tMin) > kMargin;
}

// Whether each root of a quadric along the ray in (tmin, tmax) is away from the faces' planes of
// the clip box (where the answer flips between the two roots or to a miss) and from tmin.
bool AwayFromClipBox(const RcQuadric& q, const geometry::Ray<double>& ray) {
    constexpr double kMargin = 1e-4;
    const std::array<double, 10> c = {q.c0.x, q.c0.y, q.c0.z, q.c0.w, q.c1.x,
                                      q.c1.y, q.c1.z, q.c1.w, q.c2.x, q.c2.y};
    const glm::dvec3 everywhere(std::numeric_limits<double>::infinity());
    const glm::dvec3 lo(V3(q.boxMin)), hi(V3(q.boxMax));
    geometry::Ray<double> rest = ray;
    double t = 0;
    for (int root = 0; root < 2; ++root) {
        if (!geometry::IntersectQuadric(rest, c, -everywhere, everywhere, t)) break;
        const glm::dvec3 p = ray.o + t * ray.d;
        for (int axis = 0; axis < 3; ++axis) {
            if (std::min(std::abs(p[axis] - lo[axis]), std::abs(p[axis] - hi[axis])) <= kMargin) {
                return false;
            }
        }
        if (t - ray.tMin <= kMargin) return false;
        rest.tMin = t;
    }
    return true;
}

// Whether a ray's answer for a primitive is well-conditioned: it is away from the triangle's edges
// or the quadric's clip box, and moving its origin or direction by 1e-5 along any axis neither
// changes whether it hits nor moves t by more than 1e-3 relative. That excludes tangent and
// near-tangent rays, rays through edges, vertices and clip-box rims, rays that start on the
// surface and hits at tmin or tmax, while keeping ordinary hits at any angle steeper than about
// 0.5 degrees.
bool WellConditioned(const Primitives& prims, uint32_t prim, const geometry::Ray<double>& ray,
                     bool hit, double t) {
    const auto nT = uint32_t(prims.triangles.size()), nS = uint32_t(prims.spheres.size());
    if (prim < nT && !AwayFromTriangleEdges(prims.triangles[prim], ray)) return false;
    if (prim >= nT + nS && !AwayFromClipBox(prims.quadrics[prim - nT - nS], ray)) return false;
    constexpr double kStep = 1e-5, kTolerance = 1e-3;
    for (int axis = 0; axis < 3; ++axis) {
        for (double sign : {-1.0, 1.0}) {
            for (int which = 0; which < 2; ++which) {
                geometry::Ray<double> moved = ray;
                (which == 0 ? moved.o : moved.d)[axis] += sign * kStep;
                double tm = 0, u = 0, v = 0;
                const bool hm = HostIntersect(prims, prim, moved, tm, u, v);
                if (hm != hit || (hit && std::abs(tm - t) > kTolerance * t)) return false;
            }
        }
    }
    return true;
}

// Relative tolerance of float t against double t on well-conditioned rays: the filter admits a
// relative condition number of up to about kTolerance / kStep * |o| ~ 300 (|o| <= 3 * sqrt(3)),
// the float inputs and a couple of dozen float operations each carry a relative error of 6e-8, so
// the float t may be off by up to about 300 * 24 * 6e-8 ~ 4e-4.
constexpr double kRelativeTolerance = 5e-4;

TEST(IntersectFloat, AgreesWithDoubleOnWellConditionedRays) {
    const DeviceRun& run = ProbeRun();
    const uint32_t nPrims = run.prims.Count();
    size_t compared = 0, hits = 0, failures = 0;
    double worst = 0;
    for (size_t ray = 0; ray < run.rays.rays.size(); ++ray) {
        const auto rayD = HostRay<double>(run.rays.rays[ray]);
        const auto rayF = HostRay<float>(run.rays.rays[ray]);
        for (uint32_t prim = 0; prim < nPrims; ++prim) {
            double td = 0, ud = 0, vd = 0;
            const bool hitD = HostIntersect(run.prims, prim, rayD, td, ud, vd);
            if (!WellConditioned(run.prims, prim, rayD, hitD, td)) continue;
            ++compared;
            float tf = 0, uf = 0, vf = 0;
            const bool hitF = HostIntersect(run.prims, prim, rayF, tf, uf, vf);
            if (hitF != hitD) {
                if (++failures <= 10) {
                    ADD_FAILURE() << Describe(run, ray, prim) << ": float hit " << hitF
                                  << ", double hit " << hitD << " (t=" << td << ")";
                }
                continue;
            }
            if (!hitD) continue;
            ++hits;
            const double error = std::abs(double(tf) - td) / td;
            worst = std::max(worst, error);
            if (error > kRelativeTolerance && ++failures <= 10) {
                ADD_FAILURE() << Describe(run, ray, prim) << ": float t " << tf << ", double t "
                              << td << " (relative error " << error << ")";
            }
        }
    }
    EXPECT_EQ(failures, 0u) << "worst relative error " << worst;
    // Most pairs are well-conditioned, and thousands of them are hits.
    EXPECT_GT(compared, run.rays.rays.size() * nPrims / 2);
    EXPECT_GT(hits, 10000u);
}

TEST(OffsetRayOrigin, DeviceMatchesHostBitForBit) {
    std::mt19937 rng(7);
    std::vector<rc_float4> points, normals;
    // Components at every scale the renderer meets, both signs, with exact zeros and the edges of
    // the near-origin branch (|p| < 1/32) mixed in.
    const std::vector<float> special = {0.0f,
                                        -0.0f,
                                        1.0f / 32.0f,
                                        -1.0f / 32.0f,
                                        std::nextafter(1.0f / 32.0f, 0.0f),
                                        std::nextafter(-1.0f / 32.0f, 0.0f),
                                        1e-30f,
                                        -1e-30f,
                                        1.0f,
                                        -1.0f,
                                        555.0f,
                                        -8192.0f};
    std::uniform_int_distribution<int> pick(0, 3), index(0, int(special.size()) - 1);
    std::uniform_real_distribution<float> mantissa(-1.0f, 1.0f), exponent(-12.0f, 12.0f);
    auto component = [&]() -> float {
        switch (pick(rng)) {
            case 0:
                return special[size_t(index(rng))];
            case 1:
                return mantissa(rng) / 32.0f;  // near the origin
            default:
                return mantissa(rng) * std::exp2(exponent(rng));  // 2^-12 .. 2^12, either sign
        }
    };
    for (int i = 0; i < 20000; ++i) {
        points.push_back({component(), component(), component(), 0.0f});
        // Random unit normals, and axis-aligned ones every 8th (256 whole ulps on one axis).
        glm::vec3 n = glm::vec3(RandomUnit(rng));
        if (i % 8 == 0) n = glm::vec3(0.0f), n[i / 8 % 3] = (i / 24 % 2) ? -1.0f : 1.0f;
        normals.push_back(F4(n));
    }
    auto& ctx = TestContext();
    cl::Kernel kernel(ProbeProgram(), "rc_probe_offset");
    const auto n = uint32_t(points.size());
    cl::Buffer out(ctx.context(), CL_MEM_WRITE_ONLY, n * sizeof(rc_float4));
    const cl::Buffer pointBuffer = Upload(points), normalBuffer = Upload(normals);
    kernel.setArg(0, pointBuffer);
    kernel.setArg(1, normalBuffer);
    kernel.setArg(2, n);
    kernel.setArg(3, out);
    ctx.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(n));
    const auto device = Download<rc_float4>(out, n);
    size_t mismatches = 0;
    for (uint32_t i = 0; i < n; ++i) {
        const glm::vec3 host = geometry::OffsetRayOrigin(V3(points[i]), V3(normals[i]));
        for (int c = 0; c < 3; ++c) {
            const float d = (&device[i].x)[c];
            if (std::bit_cast<uint32_t>(d) != std::bit_cast<uint32_t>(host[c]) &&
                ++mismatches <= 10) {
                ADD_FAILURE() << "p=" << (&points[i].x)[c] << " n=" << (&normals[i].x)[c]
                              << ": host " << host[c] << ", device " << d;
            }
        }
    }
    EXPECT_EQ(mismatches, 0u);
}

}  // namespace
}  // namespace rayclass::clrt
