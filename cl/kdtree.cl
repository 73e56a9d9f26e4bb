/* Ray queries through the SAH kd-tree (include/rayclass/accel/kdtree.h). A leaf names a run of
 * the tree's primitive ids (`prims`, ascending within the leaf); the primitives themselves are
 * the scene's own arrays, tested with the routines brute force uses (intersect.cl) or their
 * 16-lane twin, so the hits equal brute force's (lower id wins ties).
 *
 * A work-item answers 16 consecutive rays. A coherent packet (rc_bvh_load_packet's test: one
 * octant, a narrow cone, nearby origins) walks the tree once, float16 over its rays: each lane
 * keeps its own interval in the current cell, the packet enters a child when any live lane
 * does, and a leaf's triangles are tested one at a time against every lane. Because the lanes
 * share their directions' signs, the near child is the same for all of them. Other packets, and
 * scenes with spheres, quadrics or the watertight test, walk ray by ray: a per-ray stack of
 * (node, entry, exit), front to back.
 *
 * Both walks widen every interval by the slack (accel_common.cl), so rounding never skips a
 * cell a ray touches, and a cell waits on the stack with the distance at which the ray enters
 * it, less the slack: it is dropped once the nearest hit found since lies before that, so a hit
 * at exactly a cell boundary still meets the lower ids beyond it. counters[i] counts primitive
 * tests of ray i, counters[n + i] the nodes it visited (in a packet, those visited while it was
 * live). */
#include "rc_types.h"
#include "intersect.cl"
#include "bvh.cl"
#include "accel_common.cl"

#pragma OPENCL FP_CONTRACT OFF

/* accel::kKdMaxDepth: one entry per level. */
#define RC_KD_STACK 64

/* Walks the tree, unless the ray needs no walk (rc_ray_walks); with anyHit it returns at the
 * first hit. Returns the primitive tests done and adds the nodes visited to *visits. */
static inline uint rc_kd_trace(RcRay ray, int anyHit, __global const RcKdNode* nodes,
                               __global const uint* prims, float4 boxLo, float4 boxHi,
                               __global const RcTriangle* triangles,
                               __global const RcSphere* spheres, __global const RcQuadric* quadrics,
                               __constant const RcRenderParams* params, RcHit* best, uint* visits) {
    const float3 o = ray.origin.xyz, d = ray.direction.xyz;
    float3 inv;
    float tn, tf;
    if (!rc_accel_enter(ray, anyHit, boxLo, boxHi, params, &inv, &tn, &tf)) return 0;
    uint stackNode[RC_KD_STACK];
    float stackNear[RC_KD_STACK], stackFar[RC_KD_STACK];
    int sp = 0;
    uint node = 0, tests = 0;
    for (;;) {
        const RcKdNode nd = nodes[node];
        ++*visits;
        const uint axis = nd.word & 3u;
        if (axis != RC_KD_LEAF) {
            const float split = as_float(nd.data);
            const float oa = rc_accel_component(o, axis), da = rc_accel_component(d, axis);
            const float ts = (split - oa) * rc_accel_component(inv, axis);
            const float s = rc_accel_slack(ts, boxLo.w);
            const int lowerFirst = oa < split || (oa == split && da <= 0.0f);
            const uint lower = node + 1, upper = nd.word >> 2;
            const uint first = lowerFirst ? lower : upper, second = lowerFirst ? upper : lower;
            /* Where the plane may lie behind the origin, the ray may stay on the first side
             * throughout; where it may lie before the interval, the ray may be on the second. */
            const int needFirst = ts - s <= 0.0f || tn < ts + s;
            const int needSecond = ts + s > 0.0f && tf > ts - s;
            const float firstFar = ts - s <= 0.0f ? tf : fmin(tf, ts + s);
            const float secondNear = fmax(tn, ts - s);
            if (needFirst && needSecond) {
                stackNode[sp] = second;
                stackNear[sp] = secondNear;
                stackFar[sp++] = tf;
            }
            if (needFirst) {
                node = first;
                tf = firstFar;
            } else {
                node = second;
                tn = secondNear;
            }
            continue;
        }
        const uint count = nd.word >> 2;
        for (uint k = nd.data; k < nd.data + count; ++k) {
            ++tests;
            if (rc_intersect_primitive(prims[k], o, d, ray.origin.w, ray.direction.w, triangles,
                                       spheres, quadrics, params->nTriangles, params->nSpheres,
                                       best) &&
                anyHit)
                return tests;
        }
        for (;;) {
            if (sp == 0) return tests;
            --sp;
            if (stackNear[sp] <= best->t) break;
        }
        node = stackNode[sp];
        tn = stackNear[sp];
        tf = stackFar[sp];
    }
}

/* Walks the tree once for a coherent packet (triangles only): nearest hits in (bt, bp, bu, bv),
 * or with anyHit the lanes that found a hit in *blocked (a lane stops at its first). Per lane
 * the primitive tests (returned) and the nodes visited (*visits). A lane is live in a cell while
 * its interval there is not empty and does not begin beyond its reach (its nearest hit, or -inf
 * once blocked). */
static inline uint16 rc_kd_trace_packet(const RcBvhPacket* p, int anyHit,
                                        __global const RcKdNode* nodes, __global const uint* prims,
                                        __global const RcTriangle* triangles, float4 boxLo,
                                        float4 boxHi, float16* bt, uint16* bp, float16* bu,
                                        float16* bv, int16* blocked, uint16* visits) {
    const float slackAbs = boxLo.w;
    float16 tn, tf;
    rc_accel_clip16(p, boxLo, boxHi, &tn, &tf);
    tn = select((float16)(INFINITY), tn, p->active);
    float16 reach = *bt;
    /* The packet's rays share their directions' signs: the child on the side the first live
     * ray points away from comes first for every lane. */
    const int16 neg0 = p->active & (as_int16(p->dx) < 0), neg1 = p->active & (as_int16(p->dy) < 0),
                neg2 = p->active & (as_int16(p->dz) < 0);
    const int negative[3] = {any(neg0), any(neg1), any(neg2)};
    uint stackNode[RC_KD_STACK];
    float16 stackNear[RC_KD_STACK], stackFar[RC_KD_STACK];
    int sp = 0;
    uint node = 0;
    uint16 tests = (uint16)(0);
    for (;;) {
        const int16 live = (tn <= tf) & (tn <= reach);
        if (any(live)) {
            const RcKdNode nd = nodes[node];
            *visits += as_uint16(live) & (uint16)(1);
            const uint axis = nd.word & 3u;
            if (axis != RC_KD_LEAF) {
                const float split = as_float(nd.data);
                const float16 o = axis == 0 ? p->ox : (axis == 1 ? p->oy : p->oz);
                const float16 inv = axis == 0 ? p->ix : (axis == 1 ? p->iy : p->iz);
                /* ts: where each ray crosses the plane; before it a ray is on the first side. */
                const float16 ts = (split - o) * inv;
                const float16 s = 1e-5f * fabs(ts) + slackAbs;
                const int16 needFirst = live & (tn <= ts + s);
                const int16 needSecond = live & (tf >= ts - s);
                const uint lower = node + 1, upper = nd.word >> 2;
                const uint first = negative[axis] ? upper : lower;
                const uint second = negative[axis] ? lower : upper;
                const float16 secondNear = fmax(tn, ts - s);
                if (!any(needFirst)) {
                    node = second;
                    tn = select((float16)(INFINITY), secondNear, needSecond);
                    continue;
                }
                if (any(needSecond)) {
                    stackNode[sp] = second;
                    stackNear[sp] = select((float16)(INFINITY), secondNear, needSecond);
                    stackFar[sp++] = tf;
                }
                node = first;
                tn = select((float16)(INFINITY), tn, needFirst);
                tf = fmin(tf, ts + s);
                continue;
            }
            const uint count = nd.word >> 2;
            for (uint k = nd.data; k < nd.data + count; ++k) {
                const int16 lanes = (tn <= reach) & (tn <= tf);
                tests += as_uint16(lanes) & (uint16)(1);
                const uint prim = prims[k];
                const float3 v0 = triangles[prim].v0.xyz;
                const int16 hit =
                    rc_accel_triangle16(p, lanes, v0, triangles[prim].v1.xyz - v0,
                                        triangles[prim].v2.xyz - v0, prim, bt, bp, bu, bv);
                if (anyHit) {
                    *blocked |= hit;
                    reach = select(reach, (float16)(-INFINITY), hit);
                    if (!any(lanes & ~hit)) break;
                } else {
                    reach = *bt;
                }
            }
        }
        if (sp == 0) return tests;
        --sp;
        node = stackNode[sp];
        tn = stackNear[sp];
        tf = stackFar[sp];
    }
}

/* The coherent-packet walk's answers for rays [first, first + 16): nearest hits, or blocked
 * flags when anyHit. */
static inline void rc_kd_packet(const RcBvhPacket* p, int anyHit, uint first, uint n,
                                __global const RcKdNode* nodes, __global const uint* prims,
                                __global const RcTriangle* triangles, float4 boxLo, float4 boxHi,
                                __global RcHit* hits, __global uchar* blockedOut,
                                __global uint* counters) {
    float16 bt = p->tmax, bu = (float16)(0.0f), bv = (float16)(0.0f);
    uint16 bp = (uint16)(RC_NO_HIT), visits = (uint16)(0);
    int16 blocked = (int16)(0);
    const uint16 tests = rc_kd_trace_packet(p, anyHit, nodes, prims, triangles, boxLo, boxHi, &bt,
                                            &bp, &bu, &bv, &blocked, &visits);
    rc_accel_store_packet(anyHit, first, n, bt, bp, bu, bv, blocked, tests, visits, hits,
                          blockedOut, counters);
}

/* The answers of rays [first, first + 16): nearest hits, or with anyHit blocked flags, and
 * their counters. A coherent packet walks the tree once, other rays one by one. */
static inline void rc_kd_answer(int anyHit, __global const RcRay* rays, uint first, uint n,
                                __global const RcKdNode* nodes, __global const uint* prims,
                                float4 boxLo, float4 boxHi, __global const RcTriangle* triangles,
                                __global const RcSphere* spheres,
                                __global const RcQuadric* quadrics,
                                __constant const RcRenderParams* params, __global RcHit* hits,
                                __global uchar* blockedOut, __global uint* counters) {
    RcBvhPacket p;
    if (rc_accel_load_packet(rays, first, n, anyHit, boxLo, boxHi, params, &p)) {
        rc_kd_packet(&p, anyHit, first, n, nodes, prims, triangles, boxLo, boxHi, hits, blockedOut,
                     counters);
        return;
    }
    for (uint i = first; i < min(first + RC_PACKET, n); ++i) {
        RcHit best = rc_no_hit(rays[i].direction.w);
        uint visits = 0;
        const uint tests = rc_kd_trace(rays[i], anyHit, nodes, prims, boxLo, boxHi, triangles,
                                       spheres, quadrics, params, &best, &visits);
        rc_accel_store_ray(anyHit, i, n, best, tests, visits, hits, blockedOut, counters);
    }
}

/* One work-item per 16 rays rays[16 i, 16 i + 16). */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_intersect_kdtree(
    __global const RcRay* rays, uint n, __global const RcKdNode* nodes, __global const uint* prims,
    float4 boxLo, float4 boxHi, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global RcHit* hits, __global uint* counters) {
    const uint first = get_global_id(0) * RC_PACKET;
    if (first >= n) return;
    rc_kd_answer(0, rays, first, n, nodes, prims, boxLo, boxHi, triangles, spheres, quadrics,
                 params, hits, 0, counters);
}

/* Any hit before the light ends a ray's search; one work-item per 16 rays, as above. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_kdtree(
    __global const RcRay* rays, uint n, __global const RcKdNode* nodes, __global const uint* prims,
    float4 boxLo, float4 boxHi, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global uchar* blocked, __global uint* counters) {
    const uint first = get_global_id(0) * RC_PACKET;
    if (first >= n) return;
    rc_kd_answer(1, rays, first, n, nodes, prims, boxLo, boxHi, triangles, spheres, quadrics,
                 params, 0, blocked, counters);
}
