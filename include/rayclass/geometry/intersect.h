// Ray-primitive intersection on the host, in float (the same arithmetic as cl/intersect.cl, for
// tests and host-side queries) and in double (the reference renderer's oracle).
//
// Triangles: Moeller & Trumbore, "Fast, Minimum Storage Ray/Triangle Intersection" (1997), the
// default, or the watertight test of Woop, Benthin & Wald (2013) (--triangle-test watertight).
// Spheres: the cancellation-free discriminant of Haines et al., "Precision Improvements for
// Ray/Sphere Intersection", Ray Tracing Gems ch. 7 (2019).
// Quadrics: the implicit quadratic along the ray with the stable root pair, clipped to a box.
// Patch boxes: geometry/patch_intersect.h (Newton in float, subdivision in double).
//
// Every routine accepts only hits with tMin < t < tMax. Among equal distances the lower primitive
// id wins (HitIsBetter), in every query path, so all paths agree exactly.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <glm/glm.hpp>
#include <limits>
#include <type_traits>
#include <utility>

#include "rayclass/geometry/patch_intersect.h"
#include "rayclass/scene/scene.h"
#include "rc_types.h"

namespace rayclass::geometry {

template <typename T>
struct Ray {
    glm::vec<3, T> o;
    glm::vec<3, T> d;  // need not be unit; t is measured in units of |d|
    T tMin = T(0);
    T tMax = std::numeric_limits<T>::infinity();
};

template <typename T>
struct Hit {
    T t = std::numeric_limits<T>::infinity();
    uint32_t prim = RC_NO_HIT;
    T u = 0, v = 0;  // barycentrics of vertices 1 and 2 for triangles
    bool Valid() const { return prim != RC_NO_HIT; }
};

template <typename T>
inline bool HitIsBetter(T t, uint32_t prim, const Hit<T>& best) {
    return t < best.t || (t == best.t && prim < best.prim);
}

template <typename T>
bool IntersectTriangle(const Ray<T>& ray, const glm::vec<3, T>& p0, const glm::vec<3, T>& p1,
                       const glm::vec<3, T>& p2, T& t, T& u, T& v) {
    const auto e1 = p1 - p0;
    const auto e2 = p2 - p0;
    const auto pv = glm::cross(ray.d, e2);
    const T det = glm::dot(e1, pv);
    if (det == T(0)) return false;  // parallel or degenerate: no single hit point
    const T invDet = T(1) / det;
    const auto tv = ray.o - p0;
    u = glm::dot(tv, pv) * invDet;
    if (u < T(0) || u > T(1)) return false;
    const auto qv = glm::cross(tv, e1);
    v = glm::dot(ray.d, qv) * invDet;
    if (v < T(0) || u + v > T(1)) return false;
    t = glm::dot(e2, qv) * invDet;
    return t > ray.tMin && t < ray.tMax;
}

// Watertight ray/triangle test: Woop, Benthin & Wald, "Watertight Ray/Triangle Intersection",
// JCGT 2(1) 2013. The vertices are moved into a ray-aligned frame (shear so that the ray runs
// along +z through the origin) and the three 2D edge functions are evaluated there; a point on a
// shared edge gets the same edge-function value from both triangles, so no ray slips between
// them. Edge functions that round to exactly zero are recomputed in double (for T = float).
// Edges count as inside (a ray through an edge or vertex hits every triangle that shares it);
// the lower-id tie-break then picks one. u, v: barycentrics of vertices 1 and 2, as above.
template <typename T>
bool IntersectTriangleWatertight(const Ray<T>& ray, const glm::vec<3, T>& p0,
                                 const glm::vec<3, T>& p1, const glm::vec<3, T>& p2, T& t, T& u,
                                 T& v) {
    const auto& d = ray.d;
    int kz = 0;
    if (std::abs(d.y) > std::abs(d[kz])) kz = 1;
    if (std::abs(d.z) > std::abs(d[kz])) kz = 2;
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (d[kz] < T(0)) std::swap(kx, ky);  // keeps the winding
    if (d[kz] == T(0)) return false;      // zero direction
    const T sx = d[kx] / d[kz];
    const T sy = d[ky] / d[kz];
    const T sz = T(1) / d[kz];
    const auto a = p0 - ray.o;
    const auto b = p1 - ray.o;
    const auto c = p2 - ray.o;
    const T ax = a[kx] - sx * a[kz], ay = a[ky] - sy * a[kz];
    const T bx = b[kx] - sx * b[kz], by = b[ky] - sy * b[kz];
    const T cx = c[kx] - sx * c[kz], cy = c[ky] - sy * c[kz];
    T e0 = cx * by - cy * bx;  // weight of p0
    T e1 = ax * cy - ay * cx;  // weight of p1
    T e2 = bx * ay - by * ax;  // weight of p2
    if constexpr (std::is_same_v<T, float>) {
        if (e0 == 0.0f || e1 == 0.0f || e2 == 0.0f) {
            e0 = float(double(cx) * double(by) - double(cy) * double(bx));
            e1 = float(double(ax) * double(cy) - double(ay) * double(cx));
            e2 = float(double(bx) * double(ay) - double(by) * double(ax));
        }
    }
    if ((e0 < T(0) || e1 < T(0) || e2 < T(0)) && (e0 > T(0) || e1 > T(0) || e2 > T(0))) {
        return false;
    }
    const T det = e0 + e1 + e2;
    if (det == T(0)) return false;  // ray in the triangle's plane, or a degenerate triangle
    const T az = sz * a[kz], bz = sz * b[kz], cz = sz * c[kz];
    const T invDet = T(1) / det;
    t = (e0 * az + e1 * bz + e2 * cz) * invDet;
    u = e1 * invDet;
    v = e2 * invDet;
    return t > ray.tMin && t < ray.tMax;
}

// Which triangle test IntersectPrimitive and the kernels use (--triangle-test).
enum class TriangleTest : uint8_t { kMoller, kWatertight };

template <typename T>
bool IntersectSphere(const Ray<T>& ray, const glm::vec<3, T>& center, T radius, T& t) {
    const auto f = ray.o - center;
    const T a = glm::dot(ray.d, ray.d);
    const T b = -glm::dot(f, ray.d);  // half of the usual -b
    const auto l = f + (b / a) * ray.d;
    const T disc = a * (radius * radius - glm::dot(l, l));
    if (disc < T(0)) return false;
    const T c = glm::dot(f, f) - radius * radius;
    const T q = b + std::copysign(std::sqrt(disc), b);
    T t0 = q == T(0) ? T(0) : c / q;
    T t1 = q / a;
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > ray.tMin && t0 < ray.tMax) {
        t = t0;
        return true;
    }
    if (t1 > ray.tMin && t1 < ray.tMax) {
        t = t1;
        return true;
    }
    return false;
}

template <typename T>
T QuadricValue(const std::array<T, 10>& c, const glm::vec<3, T>& p) {
    return c[0] * p.x * p.x + c[1] * p.y * p.y + c[2] * p.z * p.z + c[3] * p.x * p.y +
           c[4] * p.x * p.z + c[5] * p.y * p.z + c[6] * p.x + c[7] * p.y + c[8] * p.z + c[9];
}

template <typename T>
glm::vec<3, T> QuadricGradient(const std::array<T, 10>& c, const glm::vec<3, T>& p) {
    return {T(2) * c[0] * p.x + c[3] * p.y + c[4] * p.z + c[6],
            T(2) * c[1] * p.y + c[3] * p.x + c[5] * p.z + c[7],
            T(2) * c[2] * p.z + c[4] * p.x + c[5] * p.y + c[8]};
}

template <typename T>
bool IntersectQuadric(const Ray<T>& ray, const std::array<T, 10>& c, const glm::vec<3, T>& lo,
                      const glm::vec<3, T>& hi, T& t) {
    const auto& o = ray.o;
    const auto& d = ray.d;
    const T a = c[0] * d.x * d.x + c[1] * d.y * d.y + c[2] * d.z * d.z + c[3] * d.x * d.y +
                c[4] * d.x * d.z + c[5] * d.y * d.z;
    const T b = T(2) * (c[0] * o.x * d.x + c[1] * o.y * d.y + c[2] * o.z * d.z) +
                c[3] * (o.x * d.y + o.y * d.x) + c[4] * (o.x * d.z + o.z * d.x) +
                c[5] * (o.y * d.z + o.z * d.y) + c[6] * d.x + c[7] * d.y + c[8] * d.z;
    const T cc = QuadricValue(c, o);
    T roots[2];
    int nRoots = 0;
    if (a == T(0)) {
        if (b == T(0)) return false;
        roots[nRoots++] = -cc / b;
    } else {
        const T disc = b * b - T(4) * a * cc;
        if (disc < T(0)) return false;
        const T q = T(-0.5) * (b + std::copysign(std::sqrt(disc), b));
        T r0 = q / a;
        T r1 = q == T(0) ? r0 : cc / q;
        if (r0 > r1) std::swap(r0, r1);
        roots[nRoots++] = r0;
        roots[nRoots++] = r1;
    }
    for (int i = 0; i < nRoots; ++i) {
        const T ti = roots[i];
        if (!(ti > ray.tMin && ti < ray.tMax)) continue;
        const auto p = o + ti * d;
        if (p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z &&
            p.z <= hi.z) {
            t = ti;
            return true;
        }
    }
    return false;
}

template <typename T>
std::array<T, 10> QuadricCoefficients(const scene::Quadric& q) {
    std::array<T, 10> c;
    for (int i = 0; i < 10; ++i) c[i] = T(q.c[i]);
    return c;
}

// The (unnormalised) geometric normal of primitive `prim` at its surface point p: the triangle's
// edge cross product, the sphere's radius vector, the quadric's gradient, the patch's derivative
// cross product at the hit's local (u, v).
inline glm::vec3 GeometricNormal(const scene::Scene& scene, uint32_t prim, const glm::vec3& p,
                                 const glm::vec2& uv = glm::vec2(0.0f)) {
    if (prim >= scene.PatchBoxBase()) {
        return glm::vec3(PatchNormal(scene.patchBoxes[prim - scene.PatchBoxBase()].p, uv.x, uv.y));
    }
    if (prim < scene.SphereBase()) {
        const auto& v = scene.triangles[prim].p;
        return glm::cross(v[1] - v[0], v[2] - v[0]);
    }
    if (prim < scene.QuadricBase()) return p - scene.spheres[prim - scene.SphereBase()].center;
    const scene::Quadric& q = scene.quadrics[prim - scene.QuadricBase()];
    return QuadricGradient(q.c, p);
}

// Tests primitive `id` of `scene` and updates `best` when the hit is better (nearer, or equally
// near with a lower id). Returns whether it updated.
template <typename T>
bool IntersectPrimitive(const scene::Scene& scene, uint32_t id, const Ray<T>& ray, Hit<T>& best,
                        TriangleTest test = TriangleTest::kMoller) {
    using V = glm::vec<3, T>;
    // A hit at exactly best.t may still win on its lower id, so the bound is one ulp beyond it.
    Ray<T> r = ray;
    r.tMax = std::min(ray.tMax, std::nextafter(best.t, std::numeric_limits<T>::infinity()));
    T t = 0, u = 0, v = 0;
    bool hit = false;
    if (id < scene.SphereBase()) {
        const auto& tri = scene.triangles[id];
        hit = test == TriangleTest::kWatertight
                  ? IntersectTriangleWatertight(r, V(tri.p[0]), V(tri.p[1]), V(tri.p[2]), t, u, v)
                  : IntersectTriangle(r, V(tri.p[0]), V(tri.p[1]), V(tri.p[2]), t, u, v);
    } else if (id < scene.QuadricBase()) {
        const auto& s = scene.spheres[id - scene.SphereBase()];
        hit = IntersectSphere(r, V(s.center), T(s.radius), t);
    } else if (id >= scene.PatchBoxBase()) {
        const scene::PatchBox& box = scene.patchBoxes[id - scene.PatchBoxBase()];
        if constexpr (std::is_same_v<T, double>) {
            hit = IntersectPatchReference(r.o, r.d, r.tMin, r.tMax, box, t, u, v);
        } else {
            hit = IntersectPatchNewton(r.o, r.d, r.tMin, r.tMax, DevicePoints(box), box.closedU,
                                       box.closedV, t, u, v);
        }
    } else {
        const auto& q = scene.quadrics[id - scene.QuadricBase()];
        hit = IntersectQuadric(r, QuadricCoefficients<T>(q), V(q.boxMin), V(q.boxMax), t);
    }
    if (!hit || !HitIsBetter(t, id, best)) return false;
    best.t = t;
    best.prim = id;
    best.u = u;
    best.v = v;
    return true;
}

// Nearest hit over every primitive: the baseline every acceleration is checked against.
template <typename T>
Hit<T> IntersectBruteForce(const scene::Scene& scene, const Ray<T>& ray,
                           TriangleTest test = TriangleTest::kMoller) {
    Hit<T> best;
    best.t = ray.tMax;
    for (uint32_t id = 0; id < scene.PrimitiveCount(); ++id) {
        IntersectPrimitive(scene, id, ray, best, test);
    }
    if (!best.Valid()) best.t = std::numeric_limits<T>::infinity();
    return best;
}

// Whether anything blocks the segment (tMin, tMax) of the ray: the shadow query.
template <typename T>
bool Occluded(const scene::Scene& scene, const Ray<T>& ray,
              TriangleTest test = TriangleTest::kMoller) {
    Hit<T> best;
    best.t = ray.tMax;
    for (uint32_t id = 0; id < scene.PrimitiveCount(); ++id) {
        if (IntersectPrimitive(scene, id, ray, best, test)) return true;
    }
    return false;
}

}  // namespace rayclass::geometry
