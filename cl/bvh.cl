/* Ray queries through the 8-wide bounding volume hierarchy (include/rayclass/bvh/bvh.h): one ray
 * per work-item, a per-ray stack, one float8 slab test for all children of a node, nearest child
 * first, the same primitive routines as every other query (intersect.cl, lower id wins ties), so
 * the hits equal brute force's exactly. Node boxes are padded on the host and the slab test's far
 * distance is widened by 2 gamma(3) (Ize 2013), so rounding never culls a primitive the routines
 * would hit. tests[i] counts primitive tests. */
#include "rc_types.h"
#include "intersect.cl"

#pragma OPENCL FP_CONTRACT OFF

/* bvh::kStackEntries: the host keeps every walk within it. */
#define RC_BVH_STACK 128

/* min and max as one instruction each: the slab test below never meets a NaN. */
inline float8 rc_min8(float8 a, float8 b) { return select(b, a, a < b); }
inline float8 rc_max8(float8 a, float8 b) { return select(b, a, a > b); }

/* 1 / d, with a zero component replaced by a huge finite value of its sign: then no slab distance
 * is 0 * infinity (NaN), and min and max can be plain selects. The boxes' padding keeps every
 * primitive strictly inside its slabs, so a ray parallel to a slab can reach the primitives only
 * from inside it (tests/render/bvh_query_test.cpp). */
inline float3 rc_bvh_inverse(float3 d) {
    const float3 inv = (float3)(1.0f) / d;
    return select(inv, copysign((float3)(1e30f), inv), isinf(inv));
}

/* Walks the tree; with anyHit it returns at the first hit. Returns the primitive tests done. */
inline uint rc_bvh_trace(float3 o, float3 d, float tmin, float tmax, int anyHit,
                         __global const RcBvh8Node* nodes, __global const uint* primIndex,
                         __global const RcTriangle* triangles, __global const RcSphere* spheres,
                         __global const RcQuadric* quadrics, uint nT, uint nS, RcHit* best) {
    const float8 ox = (float8)(o.x), oy = (float8)(o.y), oz = (float8)(o.z);
    const float3 inv = rc_bvh_inverse(d);
    const float8 ix = (float8)(inv.x), iy = (float8)(inv.y), iz = (float8)(inv.z);
    const int8 laneBit = (int8)(1, 2, 4, 8, 16, 32, 64, 128);
    /* Entries wait with the distance at which the ray enters them: one beyond the nearest hit
     * found since is dropped when popped. */
    uint stackRef[RC_BVH_STACK];
    float stackT[RC_BVH_STACK];
    int sp = 0;
    uint ref = 0, tests = 0;
    for (;;) {
        if (ref & RC_BVH8_LEAF) {
            const uint first = ref & RC_BVH8_FIRST_MASK;
            const uint count = ((ref & ~RC_BVH8_LEAF) >> RC_BVH8_COUNT_SHIFT) + 1;
            for (uint k = 0; k < count; ++k) {
                ++tests;
                if (rc_intersect_primitive(primIndex[first + k], o, d, tmin, tmax, triangles,
                                           spheres, quadrics, nT, nS, best) &&
                    anyHit)
                    return tests;
            }
        } else {
            __global const RcBvh8Node* nd = nodes + ref;
            const float8 ax = (vload8(0, nd->loX) - ox) * ix, bx = (vload8(0, nd->hiX) - ox) * ix;
            const float8 ay = (vload8(0, nd->loY) - oy) * iy, by = (vload8(0, nd->hiY) - oy) * iy;
            const float8 az = (vload8(0, nd->loZ) - oz) * iz, bz = (vload8(0, nd->hiZ) - oz) * iz;
            const float8 tn = rc_max8(rc_max8(rc_min8(ax, bx), rc_min8(ay, by)),
                                      rc_max8(rc_min8(az, bz), (float8)(tmin)));
            const float8 tf =
                rc_min8(rc_min8(rc_max8(ax, bx), rc_max8(ay, by)), rc_max8(az, bz)) * 1.0000004f;
            /* A box entered exactly at best->t may still hold a lower id at that distance. */
            const int8 enters = (tn <= rc_min8(tf, (float8)(fmin(tmax, best->t)))) &
                                (laneBit < (int8)(1 << nd->nChildren)) & laneBit;
            const int4 m4 = enters.lo | enters.hi;
            const int2 m2 = m4.lo | m4.hi;
            int mask = m2.x | m2.y;
            if (mask != 0) {
                float near[8];
                vstore8(tn, 0, near);
                /* The entered children, nearest first (insertion sort of at most eight), or
                 * in lane order when any hit ends the walk. */
                uint r[8];
                float t[8];
                int k = 0;
                for (; mask != 0; mask &= mask - 1) {
                    const int c = popcount((mask & -mask) - 1);
                    int j = k++;
                    for (; !anyHit && j > 0 && t[j - 1] > near[c]; --j) {
                        t[j] = t[j - 1];
                        r[j] = r[j - 1];
                    }
                    t[j] = near[c];
                    r[j] = nd->child[c];
                }
                for (int j = k - 1; j > 0; --j) {
                    stackRef[sp] = r[j];
                    stackT[sp++] = t[j];
                }
                ref = r[0];
                continue;
            }
        }
        for (;;) {
            if (sp == 0) return tests;
            --sp;
            if (stackT[sp] <= best->t) break;
        }
        ref = stackRef[sp];
    }
}

__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_intersect_bvh(
    __global const RcRay* rays, uint n, __global const RcBvh8Node* nodes,
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
    __global const RcRay* rays, uint n, __global const RcBvh8Node* nodes,
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
