/* Test-only kernels (tests/clrt/intersect_test.cpp) that call the routines of intersect.cl one
 * at a time, so the test can compare them with their host twins in
 * include/rayclass/geometry/intersect.h and offset.h. */
#include "intersect.cl"
#include "rc_types.h"

#pragma OPENCL FP_CONTRACT OFF

/* One work-item per (ray, primitive) pair, item = ray * nPrims + prim, primitives numbered like
 * the renderer's ids: triangles, then spheres, then quadrics. A ray's origin.w is tmin, its
 * direction.w tmax. out[item] = (hit, t, u, v) with t, u, v as float bits, all 0 on a miss
 * (u, v are 0 for spheres and quadrics). */
__kernel void rc_probe_intersect(__global const RcRay* rays, uint nRays,
                                 __global const RcTriangle* triangles, uint nTriangles,
                                 __global const RcSphere* spheres, uint nSpheres,
                                 __global const RcQuadric* quadrics, uint nQuadrics,
                                 __global uint4* out) {
    const uint nPrims = nTriangles + nSpheres + nQuadrics;
    const uint item = get_global_id(0);
    if (item >= nRays * nPrims) return;
    const uint ray = item / nPrims, id = item % nPrims;
    const float3 o = rays[ray].origin.xyz, d = rays[ray].direction.xyz;
    const float tmin = rays[ray].origin.w, tmax = rays[ray].direction.w;
    float t = 0.0f, u = 0.0f, v = 0.0f;
    int hit;
    if (id < nTriangles) {
        __global const RcTriangle* tri = triangles + id;
        hit = rc_intersect_triangle(o, d, tmin, tmax, tri->v0.xyz, tri->v1.xyz, tri->v2.xyz, &t, &u,
                                    &v);
    } else if (id < nTriangles + nSpheres) {
        hit = rc_intersect_sphere(o, d, tmin, tmax, spheres[id - nTriangles].centerRadius, &t);
    } else {
        hit = rc_intersect_quadric(o, d, tmin, tmax, quadrics + (id - nTriangles - nSpheres), &t);
    }
    out[item] = hit ? (uint4)(1u, as_uint(t), as_uint(u), as_uint(v)) : (uint4)(0u);
}

/* out[i] = rc_offset_ray_origin(points[i], normals[i]) (w = 0). */
__kernel void rc_probe_offset(__global const float4* points, __global const float4* normals, uint n,
                              __global float4* out) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    out[i] = (float4)(rc_offset_ray_origin(points[i].xyz, normals[i].xyz), 0.0f);
}
