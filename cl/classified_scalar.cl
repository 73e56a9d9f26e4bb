/* The scalar style of the classified query's kernels (cl/classified.cl): one work-item per ray,
 * one candidate at a time. Apart from classified.cl so that only the programs of frames that
 * launch it (--kernel scalar, the watertight test) carry its bitcode, which PoCL parses whole
 * at every program load. */
#include "classified.cl"

#pragma OPENCL FP_CONTRACT OFF

__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_query_scalar(
    __global const RcRay* rays, __global const uint* rayIndex, __global const uint* rayLeaf,
    uint nSlots, __global const RcLeaf* leaves, __global const RcCandidate* candidates,
    __global const RcTriangle* triangles, __global const RcSphere* spheres,
    __global const RcQuadric* quadrics, __constant const RcRenderParams* params,
    __global RcHit* hits, __global uint* tests) {
    const uint slot = get_global_id(0);
    if (slot >= nSlots) return;
    const uint id = rayIndex[slot];
    const RcLeaf leaf = leaves[rayLeaf[slot]];
    const float3 o = rays[id].origin.xyz, d = rays[id].direction.xyz;
    const float tmin = rays[id].origin.w, tmax = rays[id].direction.w;
    const float originX = rc_face_component(o, leaf.face);
    const float speed = fabs(rc_face_component(d, leaf.face));
    RcHit best = rc_no_hit(tmax);
    uint c = 0;
    for (; c < leaf.candCount; ++c) {
        const RcCandidate cand = candidates[leaf.candBegin + c];
        if (best.prim != RC_NO_HIT && originX + best.t * speed < cand.nearX) break;
        rc_intersect_primitive(cand.prim, o, d, tmin, tmax, triangles, spheres, quadrics,
                               params->nTriangles, params->nSpheres, &best);
    }
    if (best.prim == RC_NO_HIT) best.t = INFINITY;
    hits[id] = best;
    tests[slot] = c;
}

/* Any hit before tmax (the light): one work-item per shadow ray, scalar. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_scalar(
    __global const RcRay* rays, __global const uint* rayIndex, __global const uint* rayLeaf,
    uint nSlots, __global const RcLeaf* leaves, __global const RcCandidate* candidates,
    __global const RcTriangle* triangles, __global const RcSphere* spheres,
    __global const RcQuadric* quadrics, __constant const RcRenderParams* params,
    __global uchar* blocked, __global uint* tests) {
    const uint slot = get_global_id(0);
    if (slot >= nSlots) return;
    const uint id = rayIndex[slot];
    const RcLeaf leaf = leaves[rayLeaf[slot]];
    const float3 o = rays[id].origin.xyz, d = rays[id].direction.xyz;
    const float tmin = rays[id].origin.w, tmax = rays[id].direction.w;
    const float endX = rc_segment_end_x(o, d, tmin, tmax, leaf.face);
    RcHit best = rc_no_hit(tmax);
    uchar hit = 0;
    uint c = 0;
    for (; c < leaf.candCount && !hit; ++c) {
        const RcCandidate cand = candidates[leaf.candBegin + c];
        if (cand.nearX > endX) break;
        hit = rc_intersect_primitive(cand.prim, o, d, tmin, tmax, triangles, spheres, quadrics,
                                     params->nTriangles, params->nSpheres, &best);
    }
    blocked[id] = hit;
    tests[slot] = c;
}
