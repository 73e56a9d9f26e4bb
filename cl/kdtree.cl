/* Ray queries through the SAH kd-tree (include/rayclass/accel/kdtree.h): one ray per work-item,
 * a per-ray stack of (node, entry, exit) front to back, every leaf's primitives tested with the
 * routines of intersect.cl over the whole ray (lower id wins ties), so the hits equal brute
 * force's. An entry waits on the stack with the distance at which the ray enters its cell, less
 * the slack: it is dropped when the nearest hit found since lies before that, so a hit at exactly
 * a cell boundary still meets the lower ids beyond it. counters[i] counts primitive tests,
 * counters[n + i] nodes visited. */
#include "rc_types.h"
#include "intersect.cl"
#include "accel_common.cl"

#pragma OPENCL FP_CONTRACT OFF

/* accel::kKdMaxDepth: one entry per level. */
#define RC_KD_STACK 64

/* Walks the tree; with anyHit it returns at the first hit. Returns the primitive tests done and
 * adds the nodes visited to *visits. */
inline uint rc_kd_trace(float3 o, float3 d, float tmin, float tmax, int anyHit,
                        __global const RcKdNode* nodes, __global const uint* primIndex,
                        float4 boxLo, float4 boxHi, __global const RcTriangle* triangles,
                        __global const RcSphere* spheres, __global const RcQuadric* quadrics,
                        uint nT, uint nS, RcHit* best, uint* visits) {
    const float slackAbs = boxLo.w;
    const float3 inv = rc_accel_inverse(d);
    float tn = tmin, tf = tmax;
    if (!rc_accel_clip(o, inv, boxLo.xyz, boxHi.xyz, slackAbs, &tn, &tf)) return 0;
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
            const float s = rc_accel_slack(ts, slackAbs);
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
        const uint first = nd.data, count = nd.word >> 2;
        for (uint k = 0; k < count; ++k) {
            const uint id = primIndex[first + k];
            ++tests;
            if (rc_intersect_primitive(id, o, d, tmin, tmax, triangles, spheres, quadrics, nT, nS,
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

__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_intersect_kdtree(
    __global const RcRay* rays, uint n, __global const RcKdNode* nodes,
    __global const uint* primIndex, float4 boxLo, float4 boxHi,
    __global const RcTriangle* triangles, __global const RcSphere* spheres,
    __global const RcQuadric* quadrics, __constant const RcRenderParams* params,
    __global RcHit* hits, __global uint* counters) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    const float3 o = rays[i].origin.xyz, d = rays[i].direction.xyz;
    const float tmin = rays[i].origin.w, tmax = rays[i].direction.w;
    RcHit best = rc_no_hit(tmax);
    uint tests = 0, visits = 0;
    if (params->nTriangles + params->nSpheres + params->nQuadrics > 0)
        tests = rc_kd_trace(o, d, tmin, tmax, 0, nodes, primIndex, boxLo, boxHi, triangles, spheres,
                            quadrics, params->nTriangles, params->nSpheres, &best, &visits);
    if (best.prim == RC_NO_HIT) best.t = INFINITY;
    hits[i] = best;
    counters[i] = tests;
    counters[n + i] = visits;
}

/* Any hit before the light ends the search. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_kdtree(
    __global const RcRay* rays, uint n, __global const RcKdNode* nodes,
    __global const uint* primIndex, float4 boxLo, float4 boxHi,
    __global const RcTriangle* triangles, __global const RcSphere* spheres,
    __global const RcQuadric* quadrics, __constant const RcRenderParams* params,
    __global uchar* blocked, __global uint* counters) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    blocked[i] = 0;
    counters[i] = counters[n + i] = 0;
    /* An empty slot has tmax 0: nothing can block it. */
    if (rays[i].direction.w == 0.0f) return;
    if (params->nTriangles + params->nSpheres + params->nQuadrics == 0) return;
    const float3 o = rays[i].origin.xyz, d = rays[i].direction.xyz;
    const float tmin = rays[i].origin.w, tmax = rays[i].direction.w;
    RcHit best = rc_no_hit(tmax);
    uint visits = 0;
    counters[i] =
        rc_kd_trace(o, d, tmin, tmax, 1, nodes, primIndex, boxLo, boxHi, triangles, spheres,
                    quadrics, params->nTriangles, params->nSpheres, &best, &visits);
    counters[n + i] = visits;
    blocked[i] = best.prim != RC_NO_HIT;
}
