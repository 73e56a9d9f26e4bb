/* --stats: how the patch boxes' Newton iteration ends (render/newton_stats.h). Each ray of a
 * sample is tested, by rc_patch_box_newton itself, against every patch box whose box its segment
 * (tmin, tmax) enters: the tests a query that culls by the boxes alone would run. */
#include "rc_types.h"
#include "intersect.cl"

#pragma OPENCL FP_CONTRACT OFF

/* counters: tests, the Newton steps from the boxes' centres, then the tests whose search from the
 * centre ended culled, converged, diverged, left and on the cap (RC_NEWTON_*), its hits, then the
 * tests that restarted from the quarters, their steps and their hits. */
#define RC_NEWTON_COUNTERS 11

static inline int rc_segment_meets_box(float3 o, float3 inv, float tmin, float tmax, float3 lo,
                                       float3 hi) {
    const float3 a = (lo - o) * inv, b = (hi - o) * inv;
    const float3 near = fmin(a, b), far = fmax(a, b);
    const float t0 = fmax(fmax(near.x, near.y), fmax(near.z, tmin));
    const float t1 = fmin(fmin(far.x, far.y), fmin(far.z, tmax));
    return t0 <= t1;
}

__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_patch_newton_stats(
    __global const RcRay* rays, uint n, __global const RcQuadric* quadrics, uint nQuadrics,
    __global uint* counters) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    const float3 o = rays[i].origin.xyz, d = rays[i].direction.xyz;
    const float tmin = rays[i].origin.w, tmax = rays[i].direction.w;
    const float3 inv = 1.0f / d;
    uint c[RC_NEWTON_COUNTERS] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    for (uint k = 0; k < nQuadrics; ++k) {
        __global const RcPatchBox* box = (__global const RcPatchBox*)(quadrics + k);
        if (box->kind != RC_ANALYTIC_PATCH_BOX) continue;
        if (!rc_segment_meets_box(o, inv, tmin, tmax, box->boxMin.xyz, box->boxMax.xyz)) continue;
        float t, u, v;
        int outcome, steps, restartSteps;
        const int hit = rc_patch_box_newton(o, d, tmin, tmax, (__global const float4*)quadrics,
                                            box, &t, &u, &v, &outcome, &steps, &restartSteps);
        c[0] += 1;
        c[1] += (uint)steps;
        c[2 + outcome] += 1;
        if (restartSteps < 0) {
            c[7] += (uint)hit;
        } else {
            c[8] += 1;
            c[9] += (uint)restartSteps;
            c[10] += (uint)hit;
        }
    }
    for (int k = 0; k < RC_NEWTON_COUNTERS; ++k) {
        if (c[k]) atomic_add(counters + k, c[k]);
    }
}
