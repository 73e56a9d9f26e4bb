/* Brute-force ray queries: every ray against every primitive. The baseline every acceleration is
 * measured and checked against. */
#include "rc_types.h"
#include "intersect.cl"

#pragma OPENCL FP_CONTRACT OFF

__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_intersect_brute(
    __global const RcRay* rays, uint n, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global RcHit* hits) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    const float3 o = rays[i].origin.xyz, d = rays[i].direction.xyz;
    const float tmin = rays[i].origin.w, tmax = rays[i].direction.w;
    RcHit best = rc_no_hit(tmax);
    const uint nT = params->nTriangles, nS = params->nSpheres;
    const uint nPrims = nT + nS + params->nQuadrics;
    for (uint id = 0; id < nPrims; ++id)
        rc_intersect_primitive(id, o, d, tmin, tmax, triangles, spheres, quadrics, nT, nS, &best);
    if (best.prim == RC_NO_HIT) best.t = INFINITY;
    hits[i] = best;
}

/* Any hit before the light ends the search. tests[i] counts the primitives tested. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_brute(
    __global const RcRay* rays, uint n, __global const RcTriangle* triangles,
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
    const uint nPrims = nT + nS + params->nQuadrics;
    uint id = 0;
    while (id < nPrims) {
        const int hit =
            rc_intersect_primitive(id, o, d, tmin, tmax, triangles, spheres, quadrics, nT, nS, &best);
        ++id;
        if (hit) {
            blocked[i] = 1;
            break;
        }
    }
    tests[i] = id;
}
