/* Ray queries through the uniform grid (include/rayclass/accel/grid.h): one ray per work-item, a
 * 3D-DDA (Amanatides & Woo) from the cell where the ray enters the grid, every cell's primitives
 * tested with the routines of intersect.cl over the whole ray (lower id wins ties), so the hits
 * equal brute force's. Without mailboxes a primitive in several cells is tested in each, and a
 * hit found in a cell may lie in a later one: the walk ends only once the nearest hit lies
 * inside the cells walked so far (before the current cell's exit, less the slack), so a hit at
 * exactly a cell boundary still meets the lower ids beyond it. A cell's exit is computed afresh
 * from its index, so no rounding accumulates along the walk. counters[i] counts primitive
 * tests, counters[n + i] cells visited. */
#include "rc_types.h"
#include "intersect.cl"
#include "accel_common.cl"

#pragma OPENCL FP_CONTRACT OFF

/* boxLo.w: the slack's absolute part; cellSize.xyz; res.xyz: cells along each axis. */
inline uint rc_grid_trace(float3 o, float3 d, float tmin, float tmax, int anyHit,
                          __global const uint* cellStart, __global const uint* primIndex,
                          float4 boxLo, float4 boxHi, float4 cellSize, uint4 res,
                          __global const RcTriangle* triangles, __global const RcSphere* spheres,
                          __global const RcQuadric* quadrics, uint nT, uint nS, RcHit* best,
                          uint* visits) {
    const float slackAbs = boxLo.w;
    const float3 inv = rc_accel_inverse(d);
    float t0 = tmin, t1 = tmax;
    if (!rc_accel_clip(o, inv, boxLo.xyz, boxHi.xyz, slackAbs, &t0, &t1)) return 0;
    const int3 last = convert_int3(res.xyz) - 1;
    const float3 p = o + fmax(t0, 0.0f) * d;
    int3 cell = clamp(convert_int3_rtn((p - boxLo.xyz) / cellSize.xyz), (int3)(0), last);
    const int3 step = select((int3)(-1), (int3)(1), d > 0.0f);
    const int3 moves = d != 0.0f; /* -1 where the ray moves along the axis */
    const int3 upper = d > 0.0f;
    uint tests = 0;
    for (;;) {
        ++*visits;
        const uint c = (uint)cell.x + res.x * ((uint)cell.y + res.y * (uint)cell.z);
        const uint end = cellStart[c + 1];
        for (uint k = cellStart[c]; k < end; ++k) {
            const uint id = primIndex[k];
            ++tests;
            if (rc_intersect_primitive(id, o, d, tmin, tmax, triangles, spheres, quadrics, nT, nS,
                                       best) &&
                anyHit)
                return tests;
        }
        const float3 boundary =
            boxLo.xyz + convert_float3(cell + select((int3)(0), (int3)(1), upper)) * cellSize.xyz;
        const float3 tNext = select((float3)(INFINITY), (boundary - o) * inv, moves);
        const float tExit = fmin(fmin(tNext.x, tNext.y), tNext.z);
        const float s = rc_accel_slack(tExit, slackAbs);
        if (best->t < tExit - s || tExit - s > t1) return tests;
        if (tNext.x <= tNext.y && tNext.x <= tNext.z) {
            cell.x += step.x;
            if (cell.x < 0 || cell.x > last.x) return tests;
        } else if (tNext.y <= tNext.z) {
            cell.y += step.y;
            if (cell.y < 0 || cell.y > last.y) return tests;
        } else {
            cell.z += step.z;
            if (cell.z < 0 || cell.z > last.z) return tests;
        }
    }
}

__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_intersect_grid(
    __global const RcRay* rays, uint n, __global const uint* cellStart,
    __global const uint* primIndex, float4 boxLo, float4 boxHi, float4 cellSize, uint4 res,
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
        tests = rc_grid_trace(o, d, tmin, tmax, 0, cellStart, primIndex, boxLo, boxHi, cellSize,
                              res, triangles, spheres, quadrics, params->nTriangles,
                              params->nSpheres, &best, &visits);
    if (best.prim == RC_NO_HIT) best.t = INFINITY;
    hits[i] = best;
    counters[i] = tests;
    counters[n + i] = visits;
}

/* Any hit before the light ends the search. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_grid(
    __global const RcRay* rays, uint n, __global const uint* cellStart,
    __global const uint* primIndex, float4 boxLo, float4 boxHi, float4 cellSize, uint4 res,
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
    counters[i] = rc_grid_trace(o, d, tmin, tmax, 1, cellStart, primIndex, boxLo, boxHi, cellSize,
                                res, triangles, spheres, quadrics, params->nTriangles,
                                params->nSpheres, &best, &visits);
    counters[n + i] = visits;
    blocked[i] = best.prim != RC_NO_HIT;
}
