/* Ray queries through the 8-wide bounding volume hierarchy (include/rayclass/bvh/bvh.h): one ray
 * per work-item, a per-ray stack, one float8 slab test for all children of a node, nearest child
 * first, a leaf's triangles eight at a time from its blocks (bvh/leaf_blocks.h) with the
 * operations of the scalar routine, its other primitives through the routines every other query
 * uses (intersect.cl, lower id wins ties), so the hits equal brute force's exactly. Node
 * boxes are padded on the host and the slab test's far distance is widened by 2 gamma(3) (Ize
 * 2013), so rounding never culls a primitive the routines would hit. tests[i] counts primitive
 * tests. */
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

/* Moeller-Trumbore of one ray against the eight lanes of a leaf block, the same operations as
 * rc_intersect_triangle lane by lane. Returns t per lane, +inf where a lane misses or its t is not
 * below `bound`. */
inline float8 rc_bvh_triangles8(float3 o, float3 d, float tmin, float bound,
                                __global const RcBvhLeafBlock8* blk, float8* uOut, float8* vOut) {
    const float8 e1x = vload8(0, blk->e1x), e1y = vload8(0, blk->e1y), e1z = vload8(0, blk->e1z);
    const float8 e2x = vload8(0, blk->e2x), e2y = vload8(0, blk->e2y), e2z = vload8(0, blk->e2z);
    /* pv = cross(d, e2) */
    const float8 pvx = d.y * e2z - e2y * d.z;
    const float8 pvy = d.z * e2x - e2z * d.x;
    const float8 pvz = d.x * e2y - e2x * d.y;
    const float8 det = e1x * pvx + e1y * pvy + e1z * pvz;
    const float8 invDet = 1.0f / det;
    const float8 tvx = o.x - vload8(0, blk->v0x);
    const float8 tvy = o.y - vload8(0, blk->v0y);
    const float8 tvz = o.z - vload8(0, blk->v0z);
    const float8 u = (tvx * pvx + tvy * pvy + tvz * pvz) * invDet;
    /* qv = cross(tv, e1) */
    const float8 qvx = tvy * e1z - e1y * tvz;
    const float8 qvy = tvz * e1x - e1z * tvx;
    const float8 qvz = tvx * e1y - e1x * tvy;
    const float8 v = (d.x * qvx + d.y * qvy + d.z * qvz) * invDet;
    const float8 t = (e2x * qvx + e2y * qvy + e2z * qvz) * invDet;
    const int8 ok = (det != 0.0f) & (u >= 0.0f) & (u <= 1.0f) & (v >= 0.0f) & (u + v <= 1.0f) &
                    (t > tmin) & (t < bound);
    *uOut = u;
    *vOut = v;
    return select((float8)(INFINITY), t, ok);
}

/* The leaf one primitive at a time, for the watertight triangle test, which has no eight-lane
 * form: the same answer and count as rc_bvh_leaf. */
inline int rc_bvh_leaf_scalar(uint count, __global const RcBvhLeafBlock8* blk, float3 o, float3 d,
                              float tmin, float tmax, int anyHit,
                              __global const RcTriangle* triangles,
                              __global const RcSphere* spheres, __global const RcQuadric* quadrics,
                              uint nT, uint nS, RcHit* best, uint* tests) {
    for (uint k = 0; k < count; ++k) {
        ++*tests;
        if (rc_intersect_primitive(blk[k / 8].prim[k % 8], o, d, tmin, tmax, triangles, spheres,
                                   quadrics, nT, nS, best) &&
            anyHit)
            return 1;
    }
    return 0;
}

/* The leaf whose `count` primitives fill the blocks from `blk` on, with the lower-id tie-break.
 * Returns 1 when anyHit and a primitive was hit; *tests counts the primitives tested, as if one
 * at a time in lane order up to an any-hit (the count rc_intersect_primitive walks would give). */
inline int rc_bvh_leaf(uint count, __global const RcBvhLeafBlock8* blk, float3 o, float3 d,
                       float tmin, float tmax, int anyHit, __global const RcTriangle* triangles,
                       __global const RcSphere* spheres, __global const RcQuadric* quadrics,
                       uint nT, uint nS, RcHit* best, uint* tests) {
    for (uint first = 0; first < count; first += 8, ++blk) {
        const uint lanes = min(8u, count - first);
        float8 u8, v8;
        const float8 t8 = rc_bvh_triangles8(o, d, tmin, fmin(tmax, nextafter(best->t, INFINITY)),
                                            blk, &u8, &v8);
        const uint8 prim8 = vload8(0, blk->prim);
        /* Spheres and quadrics take the scalar routines. */
        const int8 other8 = (prim8 >= (uint8)(nT)) & (prim8 != (uint8)(RC_NO_HIT));
        float ts[8];
        vstore8(t8, 0, ts);
        if (anyHit) {
            for (uint k = 0; k < lanes; ++k) {
                const uint prim = blk->prim[k];
                ++*tests;
                if (prim >= nT ? rc_intersect_primitive(prim, o, d, tmin, tmax, triangles, spheres,
                                                        quadrics, nT, nS, best)
                               : ts[k] != INFINITY) {
                    best->prim = prim;
                    return 1;
                }
            }
            continue;
        }
        *tests += lanes;
        const float4 m4 = fmin(t8.lo, t8.hi);
        const float2 m2 = fmin(m4.lo, m4.hi);
        if (fmin(m2.x, m2.y) <= best->t) {
            float us[8], vs[8];
            vstore8(u8, 0, us);
            vstore8(v8, 0, vs);
            for (uint k = 0; k < lanes; ++k) {
                const uint prim = blk->prim[k];
                if (ts[k] < best->t ||
                    (ts[k] == best->t && ts[k] != INFINITY && prim < best->prim)) {
                    best->t = ts[k];
                    best->prim = prim;
                    best->u = us[k];
                    best->v = vs[k];
                }
            }
        }
        if (any(other8)) {
            for (uint k = 0; k < lanes; ++k) {
                const uint prim = blk->prim[k];
                if (prim >= nT)
                    rc_intersect_primitive(prim, o, d, tmin, tmax, triangles, spheres, quadrics,
                                           nT, nS, best);
            }
        }
    }
    return 0;
}

#ifdef RC_WATERTIGHT
#define RC_BVH_LEAF rc_bvh_leaf_scalar
#else
#define RC_BVH_LEAF rc_bvh_leaf
#endif

/* Walks the tree; with anyHit it returns at the first hit. Returns the primitive tests done. */
inline uint rc_bvh_trace(float3 o, float3 d, float tmin, float tmax, int anyHit,
                         __global const RcBvh8Node* nodes, __global const RcBvhLeafBlock8* blocks,
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
            const uint count = ((ref & ~RC_BVH8_LEAF) >> RC_BVH8_COUNT_SHIFT) + 1;
            if (RC_BVH_LEAF(count, blocks + (ref & RC_BVH8_FIRST_MASK), o, d, tmin, tmax, anyHit,
                            triangles, spheres, quadrics, nT, nS, best, &tests))
                return tests;
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
    __global const RcBvhLeafBlock8* blocks, __global const RcTriangle* triangles,
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
        count = rc_bvh_trace(o, d, tmin, tmax, 0, nodes, blocks, triangles, spheres, quadrics,
                             nT, nS, &best);
    if (best.prim == RC_NO_HIT) best.t = INFINITY;
    hits[i] = best;
    tests[i] = count;
}

/* Any hit before the light ends the search. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_bvh(
    __global const RcRay* rays, uint n, __global const RcBvh8Node* nodes,
    __global const RcBvhLeafBlock8* blocks, __global const RcTriangle* triangles,
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
    tests[i] = rc_bvh_trace(o, d, tmin, tmax, 1, nodes, blocks, triangles, spheres, quadrics,
                            nT, nS, &best);
    blocked[i] = best.prim != RC_NO_HIT;
}
