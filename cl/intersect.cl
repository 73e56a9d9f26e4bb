/* Ray-primitive intersection in float, the device twin of include/rayclass/geometry/intersect.h
 * (same formulas, same order of operations, no contraction), so host and device agree on a grid
 * of rays. Every routine accepts only tmin < t < tmax. */
#include "rc_types.h"

#pragma OPENCL FP_CONTRACT OFF
#ifdef cl_khr_fp64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#endif

/* dot and cross spelled out in glm's order of operations: the builtins may fuse or reassociate,
 * and the host twins, the vector kernels and this file must round identically. */
#define RC_DOT3(a, b) ((a).x * (b).x + (a).y * (b).y + (a).z * (b).z)
#define RC_CROSS3(a, b)                                                   \
    ((float3)((a).y * (b).z - (b).y * (a).z, (a).z * (b).x - (b).z * (a).x, \
              (a).x * (b).y - (b).x * (a).y))

#include "patch.cl"

/* Moeller & Trumbore 1997. u, v: barycentrics of vertices 1 and 2. */
static inline int rc_intersect_triangle(float3 o, float3 d, float tmin, float tmax, float3 p0,
                                        float3 p1, float3 p2, float* t, float* u, float* v) {
    const float3 e1 = p1 - p0;
    const float3 e2 = p2 - p0;
    const float3 pv = RC_CROSS3(d, e2);
    const float det = RC_DOT3(e1, pv);
    if (det == 0.0f) return 0;
    const float invDet = 1.0f / det;
    const float3 tv = o - p0;
    *u = RC_DOT3(tv, pv) * invDet;
    if (*u < 0.0f || *u > 1.0f) return 0;
    const float3 qv = RC_CROSS3(tv, e1);
    *v = RC_DOT3(d, qv) * invDet;
    if (*v < 0.0f || *u + *v > 1.0f) return 0;
    *t = RC_DOT3(e2, qv) * invDet;
    return *t > tmin && *t < tmax;
}

/* Woop, Benthin & Wald 2013, "Watertight Ray/Triangle Intersection": the twin of
 * IntersectTriangleWatertight in geometry/intersect.h (edge functions in a ray-sheared frame,
 * recomputed in double where they round to zero and the device has fp64). */
static inline int rc_intersect_triangle_watertight(float3 o, float3 d, float tmin, float tmax,
                                                   float3 p0, float3 p1, float3 p2, float* t,
                                                   float* u, float* v) {
    const float dd[3] = {d.x, d.y, d.z};
    int kz = 0;
    if (fabs(dd[1]) > fabs(dd[kz])) kz = 1;
    if (fabs(dd[2]) > fabs(dd[kz])) kz = 2;
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (dd[kz] < 0.0f) {
        const int s = kx;
        kx = ky;
        ky = s;
    }
    if (dd[kz] == 0.0f) return 0;
    const float sx = dd[kx] / dd[kz];
    const float sy = dd[ky] / dd[kz];
    const float sz = 1.0f / dd[kz];
    const float3 a3 = p0 - o, b3 = p1 - o, c3 = p2 - o;
    const float a[3] = {a3.x, a3.y, a3.z}, b[3] = {b3.x, b3.y, b3.z}, c[3] = {c3.x, c3.y, c3.z};
    const float ax = a[kx] - sx * a[kz], ay = a[ky] - sy * a[kz];
    const float bx = b[kx] - sx * b[kz], by = b[ky] - sy * b[kz];
    const float cx = c[kx] - sx * c[kz], cy = c[ky] - sy * c[kz];
    float e0 = cx * by - cy * bx;
    float e1 = ax * cy - ay * cx;
    float e2 = bx * ay - by * ax;
#ifdef cl_khr_fp64
    if (e0 == 0.0f || e1 == 0.0f || e2 == 0.0f) {
        e0 = (float)((double)cx * (double)by - (double)cy * (double)bx);
        e1 = (float)((double)ax * (double)cy - (double)ay * (double)cx);
        e2 = (float)((double)bx * (double)ay - (double)by * (double)ax);
    }
#endif
    if ((e0 < 0.0f || e1 < 0.0f || e2 < 0.0f) && (e0 > 0.0f || e1 > 0.0f || e2 > 0.0f)) return 0;
    const float det = e0 + e1 + e2;
    if (det == 0.0f) return 0;
    const float az = sz * a[kz], bz = sz * b[kz], cz = sz * c[kz];
    const float invDet = 1.0f / det;
    *t = (e0 * az + e1 * bz + e2 * cz) * invDet;
    *u = e1 * invDet;
    *v = e2 * invDet;
    return *t > tmin && *t < tmax;
}

/* The triangle test of the render program: -DRC_WATERTIGHT=1 (--triangle-test watertight). */
#ifdef RC_WATERTIGHT
#define RC_TRIANGLE_TEST rc_intersect_triangle_watertight
#else
#define RC_TRIANGLE_TEST rc_intersect_triangle
#endif

/* Cancellation-free discriminant, Ray Tracing Gems ch. 7. */
static inline int rc_intersect_sphere(float3 o, float3 d, float tmin, float tmax,
                                      float4 centerRadius, float* t) {
    const float3 f = o - centerRadius.xyz;
    const float r = centerRadius.w;
    const float a = RC_DOT3(d, d);
    const float b = -RC_DOT3(f, d);
    const float3 l = f + (b / a) * d;
    const float disc = a * (r * r - RC_DOT3(l, l));
    if (disc < 0.0f) return 0;
    const float c = RC_DOT3(f, f) - r * r;
    const float q = b + copysign(sqrt(disc), b);
    float t0 = q == 0.0f ? 0.0f : c / q;
    float t1 = q / a;
    if (t0 > t1) {
        const float s = t0;
        t0 = t1;
        t1 = s;
    }
    if (t0 > tmin && t0 < tmax) {
        *t = t0;
        return 1;
    }
    if (t1 > tmin && t1 < tmax) {
        *t = t1;
        return 1;
    }
    return 0;
}

static inline float rc_quadric_value(float4 c0, float4 c1, float4 c2, float3 p) {
    return c0.x * p.x * p.x + c0.y * p.y * p.y + c0.z * p.z * p.z + c0.w * p.x * p.y +
           c1.x * p.x * p.z + c1.y * p.y * p.z + c1.z * p.x + c1.w * p.y + c2.x * p.z + c2.y;
}

static inline float3 rc_quadric_gradient(float4 c0, float4 c1, float4 c2, float3 p) {
    return (float3)(2.0f * c0.x * p.x + c0.w * p.y + c1.x * p.z + c1.z,
                    2.0f * c0.y * p.y + c0.w * p.x + c1.y * p.z + c1.w,
                    2.0f * c0.z * p.z + c1.x * p.x + c1.y * p.y + c2.x);
}

static inline int rc_inside_box(float3 p, float3 lo, float3 hi) {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
}

/* The quadric along the ray, a t^2 + b t + c, with the stable root pair; the nearest root in
 * (tmin, tmax) whose point lies in the clip box wins. */
static inline int rc_intersect_quadric(float3 o, float3 d, float tmin, float tmax,
                                       __global const RcQuadric* q, float* t) {
    const float4 c0 = q->c0, c1 = q->c1, c2 = q->c2;
    const float a = c0.x * d.x * d.x + c0.y * d.y * d.y + c0.z * d.z * d.z + c0.w * d.x * d.y +
                    c1.x * d.x * d.z + c1.y * d.y * d.z;
    const float b = 2.0f * (c0.x * o.x * d.x + c0.y * o.y * d.y + c0.z * o.z * d.z) +
                    c0.w * (o.x * d.y + o.y * d.x) + c1.x * (o.x * d.z + o.z * d.x) +
                    c1.y * (o.y * d.z + o.z * d.y) + c1.z * d.x + c1.w * d.y + c2.x * d.z;
    const float c = rc_quadric_value(c0, c1, c2, o);
    float roots[2];
    int nRoots = 0;
    if (a == 0.0f) {
        if (b == 0.0f) return 0;
        roots[nRoots++] = -c / b;
    } else {
        const float disc = b * b - 4.0f * a * c;
        if (disc < 0.0f) return 0;
        const float qq = -0.5f * (b + copysign(sqrt(disc), b));
        float r0 = qq / a;
        float r1 = qq == 0.0f ? r0 : c / qq;
        if (r0 > r1) {
            const float s = r0;
            r0 = r1;
            r1 = s;
        }
        roots[nRoots++] = r0;
        roots[nRoots++] = r1;
    }
    const float3 lo = q->boxMin.xyz, hi = q->boxMax.xyz;
    for (int i = 0; i < nRoots; ++i) {
        const float ti = roots[i];
        if (!(ti > tmin && ti < tmax)) continue;
        if (rc_inside_box(o + ti * d, lo, hi)) {
            *t = ti;
            return 1;
        }
    }
    return 0;
}

/* Waechter & Binder, Ray Tracing Gems ch. 6: move p off the surface by 256 ulps along n (unit,
 * on the side the new ray leaves towards), or by an absolute 2^-16 near the origin. */
static inline float rc_offset_component(float p, float n) {
    const int ulps = convert_int_rtz(256.0f * n);
    const float stepped = as_float(as_int(p) + (p < 0.0f ? -ulps : ulps));
    return fabs(p) < (1.0f / 32.0f) ? p + (1.0f / 65536.0f) * n : stepped;
}

static inline float3 rc_offset_ray_origin(float3 p, float3 n) {
    return (float3)(rc_offset_component(p.x, n.x), rc_offset_component(p.y, n.y),
                    rc_offset_component(p.z, n.z));
}

/* No hit yet on the segment (tmin, tmax): the start of every nearest-hit and any-hit search. */
static inline RcHit rc_no_hit(float tmax) {
    RcHit h;
    h.t = tmax;
    h.prim = RC_NO_HIT;
    h.u = h.v = 0.0f;
    return h;
}

/* Nearest hit of one ray over primitive `id`, with the lower-id tie-break. Returns 1 when it
 * improved *best. */
static inline int rc_intersect_primitive(uint id, float3 o, float3 d, float tmin, float tmax,
                                         __global const RcTriangle* triangles,
                                         __global const RcSphere* spheres,
                                         __global const RcQuadric* quadrics, uint nTriangles,
                                         uint nSpheres, RcHit* best) {
    /* A hit at exactly best->t may still win on its lower id. */
    const float bound = fmin(tmax, nextafter(best->t, INFINITY));
    float t = 0.0f, u = 0.0f, v = 0.0f;
    int hit;
    if (id < nTriangles) {
        __global const RcTriangle* tri = triangles + id;
        hit = RC_TRIANGLE_TEST(o, d, tmin, bound, tri->v0.xyz, tri->v1.xyz, tri->v2.xyz, &t, &u,
                               &v);
    } else if (id < nTriangles + nSpheres) {
        hit = rc_intersect_sphere(o, d, tmin, bound, spheres[id - nTriangles].centerRadius, &t);
    } else {
        __global const RcQuadric* q = quadrics + (id - nTriangles - nSpheres);
        hit = q->kind == RC_ANALYTIC_PATCH_BOX
                  ? rc_intersect_patch_box(o, d, tmin, bound, (__global const float4*)quadrics,
                                           (__global const RcPatchBox*)q, &t, &u, &v)
                  : rc_intersect_quadric(o, d, tmin, bound, q, &t);
    }
    if (!hit || !(t < best->t || (t == best->t && id < best->prim))) return 0;
    best->t = t;
    best->prim = id;
    best->u = u;
    best->v = v;
    return 1;
}
