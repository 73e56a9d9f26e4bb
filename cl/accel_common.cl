/* What the kd-tree, grid and cone kernels share: a ray's inverse direction without infinities, the
 * slack by which they widen ray intervals so that float rounding never skips a cell a ray
 * touches, a ray's interval inside a box (one ray, or a packet's lanes), the test of one
 * triangle against a packet of 16 rays (the BVH's packets, bvh.cl), and how the answers and
 * counters of a packet or a single ray are written. */
#include "rc_types.h"
#include "bvh.cl"

#pragma OPENCL FP_CONTRACT OFF

/* 1 / d, with a zero component replaced by a huge finite value of its sign: a slab distance is
 * then never 0 * infinity (NaN). */
static inline float3 rc_accel_inverse(float3 d) {
    const float3 inv = (float3)(1.0f) / d;
    return select(inv, copysign((float3)(1e30f), inv), isinf(inv));
}

/* How far a computed distance t along a ray may be from the true one, with room to spare:
 * widening an interval by it only ever visits more cells. */
static inline float rc_accel_slack(float t, float slackAbs) { return 1e-5f * fabs(t) + slackAbs; }

/* Narrows [*t0, *t1] to the ray's interval inside [lo, hi], widened by the slack; 0 when it is
 * empty. */
static inline int rc_accel_clip(float3 o, float3 inv, float3 lo, float3 hi, float slackAbs,
                                float* t0, float* t1) {
    const float3 a = (lo - o) * inv, b = (hi - o) * inv;
    const float3 near = fmin(a, b), far = fmax(a, b);
    const float tn = fmax(fmax(near.x, near.y), near.z);
    const float tf = fmin(fmin(far.x, far.y), far.z);
    *t0 = fmax(*t0, tn - rc_accel_slack(tn, slackAbs));
    *t1 = fmin(*t1, tf + rc_accel_slack(tf, slackAbs));
    return *t0 <= *t1;
}

/* A single ray's entry into the box [boxLo, boxHi] (boxLo.w: the slack's absolute part): its
 * inverse direction, and its interval inside the box, widened by the slack, in [*t0, *t1].
 * Returns 0 where it needs no walk (rc_ray_walks) or misses the box. */
static inline int rc_accel_enter(RcRay ray, int anyHit, float4 boxLo, float4 boxHi,
                                 __constant const RcRenderParams* params, float3* inv, float* t0,
                                 float* t1) {
    if (!rc_ray_walks(anyHit, ray.direction.w, params)) return 0;
    *inv = rc_accel_inverse(ray.direction.xyz);
    *t0 = ray.origin.w;
    *t1 = ray.direction.w;
    return rc_accel_clip(ray.origin.xyz, *inv, boxLo.xyz, boxHi.xyz, boxLo.w, t0, t1);
}

/* rc_accel_clip lane by lane: each lane's [tmin, tmax] narrowed to its interval inside the box
 * [boxLo, boxHi], widened by the slack (boxLo.w its absolute part), in [*tn, *tf]. */
static inline void rc_accel_clip16(const RcBvhPacket* p, float4 boxLo, float4 boxHi, float16* tn,
                                   float16* tf) {
    const float16 ax = (boxLo.x - p->ox) * p->ix, bx = (boxHi.x - p->ox) * p->ix;
    const float16 ay = (boxLo.y - p->oy) * p->iy, by = (boxHi.y - p->oy) * p->iy;
    const float16 az = (boxLo.z - p->oz) * p->iz, bz = (boxHi.z - p->oz) * p->iz;
    const float16 near = fmax(fmax(fmin(ax, bx), fmin(ay, by)), fmin(az, bz));
    const float16 far = fmin(fmin(fmax(ax, bx), fmax(ay, by)), fmax(az, bz));
    *tf = fmin(p->tmax, far + (1e-5f * fabs(far) + boxLo.w));
    *tn = fmax(p->tmin, near - (1e-5f * fabs(near) + boxLo.w));
}

/* Component `axis` (0, 1, 2) of v. */
static inline float rc_accel_component(float3 v, uint axis) {
    return axis == 0 ? v.x : (axis == 1 ? v.y : v.z);
}

/* The triangle (v0, edges e1 = v1 - v0 and e2 = v2 - v0 as rc_intersect_triangle rounds them)
 * against every lane of the packet, with rc_intersect_triangle's operations lane by lane: where
 * a lane of `live` hits it before its nearest hit (or at the same distance with a lower id),
 * that hit replaces the lane's. Returns the lanes that hit it. */
static inline int16 rc_accel_triangle16(const RcBvhPacket* p, int16 live, float3 v0, float3 e1,
                                        float3 e2, uint prim, float16* bt, uint16* bp, float16* bu,
                                        float16* bv) {
    const float16 pvx = p->dy * e2.z - e2.y * p->dz;
    const float16 pvy = p->dz * e2.x - e2.z * p->dx;
    const float16 pvz = p->dx * e2.y - e2.x * p->dy;
    const float16 det = e1.x * pvx + e1.y * pvy + e1.z * pvz;
    const float16 invDet = 1.0f / det;
    const float16 tvx = p->ox - v0.x;
    const float16 tvy = p->oy - v0.y;
    const float16 tvz = p->oz - v0.z;
    const float16 u = (tvx * pvx + tvy * pvy + tvz * pvz) * invDet;
    const float16 qvx = tvy * e1.z - e1.y * tvz;
    const float16 qvy = tvz * e1.x - e1.z * tvx;
    const float16 qvz = tvx * e1.y - e1.x * tvy;
    const float16 v = (p->dx * qvx + p->dy * qvy + p->dz * qvz) * invDet;
    const float16 t = (e2.x * qvx + e2.y * qvy + e2.z * qvz) * invDet;
    const uint16 prim16 = (uint16)(prim);
    const int16 hit = live & (det != 0.0f) & (u >= 0.0f) & (u <= 1.0f) & (v >= 0.0f) &
                      (u + v <= 1.0f) & (t > p->tmin) & (t < p->tmax) &
                      ((t < *bt) | ((t == *bt) & (prim16 < *bp)));
    *bt = select(*bt, t, hit);
    *bp = select(*bp, prim16, as_uint16(hit));
    *bu = select(*bu, u, hit);
    *bv = select(*bv, v, hit);
    return hit;
}

/* The largest spread of a packet's origins that walks as one, squared: as the BVH's rule, a
 * 32nd of the scene box's diagonal. */
static inline float rc_accel_max_spread2(float4 boxLo, float4 boxHi) {
    const float3 e = (boxHi.xyz - boxLo.xyz) * (1.0f / 32.0f);
    return dot(e, e);
}

/* A packet walk's answers for rays [first, first + 16): nearest hits, or blocked flags when
 * anyHit; counters[ray] the primitive tests, counters[n + ray] the cells or nodes visited. */
static inline void rc_accel_store_packet(int anyHit, uint first, uint n, float16 bt, uint16 bp,
                                         float16 bu, float16 bv, int16 blocked, uint16 tests,
                                         uint16 visits, __global RcHit* hits,
                                         __global uchar* blockedOut, __global uint* counters) {
    rc_packet_store_answers(anyHit, first, n, bt, bp, bu, bv, blocked, 0, hits, blockedOut);
    rc_packet_store_counts(first, n, tests, 0, counters);
    rc_packet_store_counts(first, n, visits, 0, counters + n);
}

/* A single ray's answer (rc_ray_store_answer) and counters: counters[i] its primitive tests,
 * counters[n + i] the cells or nodes it visited. */
static inline void rc_accel_store_ray(int anyHit, uint i, uint n, RcHit best, uint tests,
                                      uint visits, __global RcHit* hits, __global uchar* blockedOut,
                                      __global uint* counters) {
    rc_ray_store_answer(anyHit, i, best, hits, blockedOut);
    counters[i] = tests;
    counters[n + i] = visits;
}

/* Loads rays [first, first + 16) into *p; returns whether they walk as one packet: packets are
 * allowed (rc_packets_allowed) and the rays coherent by the BVH's rule, their origins' spread
 * measured against the scene box. */
static inline int rc_accel_load_packet(__global const RcRay* rays, uint first, uint n,
                                       int skipEmpty, float4 boxLo, float4 boxHi,
                                       __constant const RcRenderParams* params, RcBvhPacket* p) {
    return rc_packets_allowed(params) &&
           rc_bvh_load_packet(rays, 0, first, n, skipEmpty, rc_accel_max_spread2(boxLo, boxHi), p);
}
