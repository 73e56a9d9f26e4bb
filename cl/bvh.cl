/* Ray queries through the bounding volume hierarchy (include/rayclass/bvh/bvh.h): one ray per
 * work-item, a per-ray stack, near child first, the same primitive routines as every other query
 * (intersect.cl, lower id wins ties), so the hits equal brute force's exactly. Node boxes are
 * padded on the host and the slab test's far distance is widened by 2 gamma(3) (Ize 2013), so
 * rounding never culls a primitive the routines would hit. tests[i] counts primitive tests. */
#include "rc_types.h"
#include "intersect.cl"

#pragma OPENCL FP_CONTRACT OFF

#define RC_BVH_STACK 64

/* Entry distance of the ray into the node's box within [tmin, tmax], or INFINITY if it misses. */
inline float rc_bvh_enter(float3 o, float3 inv, float tmin, float tmax,
                          __global const RcBvhNode* node) {
    const float3 t0 = (node->boxMin.xyz - o) * inv;
    const float3 t1 = (node->boxMax.xyz - o) * inv;
    const float3 a = fmin(t0, t1), b = fmax(t0, t1);
    const float tn = fmax(fmax(a.x, a.y), fmax(a.z, tmin));
    const float tf = fmin(fmin(b.x, b.y), b.z) * 1.0000004f;
    return tn <= fmin(tf, tmax) ? tn : INFINITY;
}

/* Walks the tree; with anyHit it returns at the first hit. Returns the primitive tests done. */
inline uint rc_bvh_trace(float3 o, float3 d, float tmin, float tmax, int anyHit,
                         __global const RcBvhNode* nodes, __global const uint* primIndex,
                         __global const RcTriangle* triangles, __global const RcSphere* spheres,
                         __global const RcQuadric* quadrics, uint nT, uint nS, RcHit* best) {
    const float3 inv = (float3)(1.0f / d.x, 1.0f / d.y, 1.0f / d.z);
    uint stack[RC_BVH_STACK];
    int sp = 0;
    uint node = 0, tests = 0;
    for (;;) {
        __global const RcBvhNode* nd = nodes + node;
        /* A box entered exactly at best->t may still hold a lower id at that distance. */
        if (rc_bvh_enter(o, inv, tmin, fmin(tmax, best->t), nd) != INFINITY) {
            const uint count = nd->count;
            if (count == 0) {
                const uint axis = nd->axis;
                const float da = axis == 0 ? d.x : (axis == 1 ? d.y : d.z);
                const uint lo = node + 1, hi = nd->first;
                stack[sp++] = da < 0.0f ? lo : hi;
                node = da < 0.0f ? hi : lo;
                continue;
            }
            const uint first = nd->first;
            for (uint k = 0; k < count; ++k) {
                ++tests;
                if (rc_intersect_primitive(primIndex[first + k], o, d, tmin, tmax, triangles,
                                           spheres, quadrics, nT, nS, best) &&
                    anyHit)
                    return tests;
            }
        }
        if (sp == 0) break;
        node = stack[--sp];
    }
    return tests;
}

__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_intersect_bvh(
    __global const RcRay* rays, uint n, __global const RcBvhNode* nodes,
    __global const uint* primIndex, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global RcHit* hits, __global uint* tests) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    const float3 o = rays[i].origin.xyz, d = rays[i].direction.xyz;
    const float tmin = rays[i].origin.w, tmax = rays[i].direction.w;
    RcHit best = rc_no_hit(tmax);
    const uint nT = params->nTriangles, nS = params->nSpheres;
    uint count = 0;
    if (nT + nS + params->nQuadrics > 0)
        count = rc_bvh_trace(o, d, tmin, tmax, 0, nodes, primIndex, triangles, spheres, quadrics,
                             nT, nS, &best);
    if (best.prim == RC_NO_HIT) best.t = INFINITY;
    hits[i] = best;
    tests[i] = count;
}

/* Any hit before the light ends the search. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_bvh(
    __global const RcRay* rays, uint n, __global const RcBvhNode* nodes,
    __global const uint* primIndex, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global uchar* blocked, __global uint* tests) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    blocked[i] = 0;
    tests[i] = 0;
    /* An empty slot has tmax 0: nothing can block it. */
    if (rays[i].direction.w == 0.0f) return;
    const float3 o = rays[i].origin.xyz, d = rays[i].direction.xyz;
    const float tmin = rays[i].origin.w, tmax = rays[i].direction.w;
    RcHit best = rc_no_hit(tmax);
    const uint nT = params->nTriangles, nS = params->nSpheres;
    if (nT + nS + params->nQuadrics == 0) return;
    tests[i] = rc_bvh_trace(o, d, tmin, tmax, 1, nodes, primIndex, triangles, spheres, quadrics,
                            nT, nS, &best);
    blocked[i] = best.prim != RC_NO_HIT;
}
