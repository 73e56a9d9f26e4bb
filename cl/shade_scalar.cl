/* Scalar shading, a ray a work-item: the tests' oracle for rc_shade16_ids. Apart from shade.cl so
 * that a frame's program (RenderProgramFiles), which never launches it, carries no bitcode of it:
 * PoCL parses a program's whole bitcode at every load. */
#include "shade.cl"

#pragma OPENCL FP_CONTRACT OFF

/* Every ray of the batch, lights included, a ray a work-item: the renderer shades with
 * rc_shade16_ids (cl/shade16.cl), and the tests hold that to this. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_shade(
    __global const RcRay* rays, __global const RcRayInfo* infos, __global const RcHit* hits, uint n,
    RC_SHADE_SCENE_PARAMS, RC_SHADE_OUT_PARAMS) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    const RcRay ray = rays[i];
    const RcRayInfo info = rc_ray_info(infos, i);
    rc_shade_ray(i, &ray, &info, hits[i], RC_SHADE_SCENE_ARGS, RC_SHADE_OUT_ARGS);
}
