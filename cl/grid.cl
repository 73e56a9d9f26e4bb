/* Ray queries through the uniform grid (include/rayclass/accel/grid.h), every cell's primitives
 * tested with the routines of intersect.cl (or their float16 twin, accel_common.cl) over the
 * whole ray, lower id wins ties, so the hits equal brute force's. Without mailboxes a primitive
 * in several cells is tested in each, and a hit found in a cell may lie in a later one: a walk
 * ends only once the nearest hit lies inside the cells walked so far (before their exit, less
 * the slack), so a hit at exactly a cell boundary still meets the lower ids beyond it.
 *
 * A work-item answers 16 consecutive rays. A coherent packet (rc_bvh_load_packet's test) walks
 * the grid slice by slice along the axis its directions follow most (Wald et al. 2006,
 * coherent grid traversal): in each slice, every cell of the box that holds the packet's rays
 * there (their points at the slice's two faces, widened by the slack) is tested against the
 * rays in the slice, one triangle at a time against all 16. Other packets, and scenes with
 * spheres, quadrics or the watertight test, walk ray by ray with a 3D-DDA (Amanatides & Woo)
 * from the cell where the ray enters the grid; a cell's exit is computed afresh from its
 * index, so no rounding accumulates along the walk. counters[i] counts primitive tests of ray i,
 * counters[n + i] the cells visited for it. */
#include "accel_common.cl"
#include "bvh.cl"
#include "intersect.cl"
#include "rc_types.h"

#pragma OPENCL FP_CONTRACT OFF

/* Walks the cells, unless the ray needs no walk (rc_ray_walks); with anyHit it returns at the
 * first hit. Returns the primitive tests done and adds the cells visited to *visits. boxLo.w:
 * the slack's absolute part; cellSize.xyz; res.xyz: cells along each axis. */
static inline uint rc_grid_trace(RcRay ray, int anyHit, __global const uint* cellStart,
                                 __global const uint* primIndex, float4 boxLo, float4 boxHi,
                                 float4 cellSize, uint4 res, __global const RcTriangle* triangles,
                                 __global const RcSphere* spheres,
                                 __global const RcQuadric* quadrics,
                                 __constant const RcRenderParams* params, RcHit* best,
                                 uint* visits) {
    const float3 o = ray.origin.xyz, d = ray.direction.xyz;
    float3 inv;
    float t0, t1;
    if (!rc_accel_enter(ray, anyHit, boxLo, boxHi, params, &inv, &t0, &t1)) return 0;
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
            if (rc_intersect_primitive(id, o, d, ray.origin.w, ray.direction.w, triangles, spheres,
                                       quadrics, params->nTriangles, params->nSpheres, best) &&
                anyHit)
                return tests;
        }
        const float3 boundary =
            boxLo.xyz + convert_float3(cell + select((int3)(0), (int3)(1), upper)) * cellSize.xyz;
        const float3 tNext = select((float3)(INFINITY), (boundary - o) * inv, moves);
        const float tExit = fmin(fmin(tNext.x, tNext.y), tNext.z);
        const float s = rc_accel_slack(tExit, boxLo.w);
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

/* Component `axis` of a packet's float16 triple. */
static inline float16 rc_grid_lane_axis(float16 x, float16 y, float16 z, uint axis) {
    return axis == 0 ? x : (axis == 1 ? y : z);
}

/* The cells [*c0, *c1] along one axis (origin lo, cell size, res cells) that hold the points
 * o + t d for t in [t0, t1] of the lanes `in`. */
static inline void rc_grid_lane_range(float16 o, float16 d, float16 t0, float16 t1, int16 in,
                                      float lo, float size, uint res, int* c0, int* c1) {
    const float16 a = o + t0 * d, b = o + t1 * d;
    const float lowest = rc_hmin16(select((float16)(INFINITY), fmin(a, b), in));
    const float highest = rc_hmax16(select((float16)(-INFINITY), fmax(a, b), in));
    *c0 = clamp((int)floor((lowest - lo) / size), 0, (int)res - 1);
    *c1 = clamp((int)floor((highest - lo) / size), 0, (int)res - 1);
}

/* The lanes' parameter intervals [*t0, *t1] inside slices [s0, s1] along the slicing axis
 * (origin component ok, inverse direction ik), widened by the slack and clipped to [tn, tf]. */
static inline void rc_grid_slab(float lo, float size, int s0, int s1, float16 ok, float16 ik,
                                float16 tn, float16 tf, float slackAbs, float16* t0, float16* t1) {
    const float16 ta = (lo + (float)s0 * size - ok) * ik;
    const float16 tb = (lo + (float)(s1 + 1) * size - ok) * ik;
    const float16 ea = fmin(ta, tb), eb = fmax(ta, tb);
    *t0 = fmax(tn, ea - (1e-5f * fabs(ea) + slackAbs));
    *t1 = fmin(tf, eb + (1e-5f * fabs(eb) + slackAbs));
}

/* Whether a macro cell of slab mk along axis k, rows [u0, u1] x [w0, w1] of cells (one more on
 * each side, against rounding) along axes u and w, holds a primitive. mres: macro cells an
 * axis, mres.w: cells a macro cell along each axis. */
static inline int rc_grid_macro_any(__global const uchar* macroOccupied, uint4 mres, uint k, uint u,
                                    uint w, int mk, int u0, int u1, int w0, int w1) {
    const uint m = mres.w;
    const uint r[3] = {mres.x, mres.y, mres.z};
    uint mc[3];
    mc[k] = (uint)mk;
    const int mu1 = min((u1 + 1) / (int)m, (int)r[u] - 1);
    const int mw1 = min((w1 + 1) / (int)m, (int)r[w] - 1);
    for (int mw = max(w0 - 1, 0) / (int)m; mw <= mw1; ++mw) {
        mc[w] = (uint)mw;
        for (int mu = max(u0 - 1, 0) / (int)m; mu <= mu1; ++mu) {
            mc[u] = (uint)mu;
            if (macroOccupied[mc[0] + mres.x * (mc[1] + mres.y * mc[2])]) return 1;
        }
    }
    return 0;
}

/* Walks the grid once for a coherent packet (triangles only): nearest hits in (bt, bp, bu, bv),
 * or with anyHit the lanes that found a hit in *blocked. Per lane the primitive tests (returned)
 * and the cells visited (*visits). A lane takes part in a slice while its interval reaches
 * into the slice and its nearest hit (-inf once blocked) does not lie before it. The slices go
 * a slab of macro cells at a time: a slab whose macro cells under the lanes are all empty is
 * passed over whole. */
static inline uint16 rc_grid_trace_packet(
    const RcBvhPacket* p, int anyHit, __global const uint* cellStart,
    __global const uint* primIndex, __global const uchar* macroOccupied, float4 boxLo, float4 boxHi,
    float4 cellSize, uint4 res, __global const RcTriangle* triangles, float16* bt, uint16* bp,
    float16* bu, float16* bv, int16* blocked, uint16* visits) {
    const float slackAbs = boxLo.w;
    float16 tn, tf;
    rc_accel_clip16(p, boxLo, boxHi, &tn, &tf);
    const int16 inGrid = p->active & (tn <= tf);
    uint16 tests = (uint16)(0);
    if (!any(inGrid)) return tests;
    float16 reach = *bt;
    /* The slicing axis k: the one the directions follow most; u and w are the other two. */
    const float sx = rc_hmax16(select((float16)(0.0f), fabs(p->dx), inGrid));
    const float sy = rc_hmax16(select((float16)(0.0f), fabs(p->dy), inGrid));
    const float sz = rc_hmax16(select((float16)(0.0f), fabs(p->dz), inGrid));
    const uint k = sx >= sy && sx >= sz ? 0 : (sy >= sz ? 1 : 2);
    const uint u = k == 0 ? 1 : 0, w = k == 2 ? 1 : 2;
    const float lo[3] = {boxLo.x, boxLo.y, boxLo.z}, size[3] = {cellSize.x, cellSize.y, cellSize.z};
    const uint r[3] = {res.x, res.y, res.z};
    const int m = (int)res.w;
    const uint4 mres = (uint4)((res.xyz + res.w - 1) / res.w, res.w);
    const float16 ok = rc_grid_lane_axis(p->ox, p->oy, p->oz, k);
    const float16 ik = rc_grid_lane_axis(p->ix, p->iy, p->iz, k);
    const float16 ou = rc_grid_lane_axis(p->ox, p->oy, p->oz, u);
    const float16 du = rc_grid_lane_axis(p->dx, p->dy, p->dz, u);
    const float16 ow = rc_grid_lane_axis(p->ox, p->oy, p->oz, w);
    const float16 dw = rc_grid_lane_axis(p->dx, p->dy, p->dz, w);
    const float16 dk = rc_grid_lane_axis(p->dx, p->dy, p->dz, k);
    /* The slices the lanes' intervals reach, one more on each side for rounding. */
    int first, last;
    rc_grid_lane_range(ok, dk, tn, tf, inGrid, lo[k], size[k], r[k], &first, &last);
    first = max(first - 1, 0);
    last = min(last + 1, (int)r[k] - 1);
    const int backwards = any(inGrid & (as_int16(dk) < 0));
    const int step = backwards ? -1 : 1;
    int u0, u1, w0, w1;
    float16 t0, t1;
    for (int mk = (backwards ? last : first) / m; mk >= first / m && mk <= last / m; mk += step) {
        const int s0 = max(mk * m, first), s1 = min(mk * m + m - 1, last);
        rc_grid_slab(lo[k], size[k], s0, s1, ok, ik, tn, tf, slackAbs, &t0, &t1);
        const int16 pendingSlab = inGrid & (t0 <= reach);
        if (!any(pendingSlab & (t0 <= tf))) break;
        const int16 inSlab = pendingSlab & (t0 <= t1);
        if (!any(inSlab)) continue;
        rc_grid_lane_range(ou, du, t0, t1, inSlab, lo[u], size[u], r[u], &u0, &u1);
        rc_grid_lane_range(ow, dw, t0, t1, inSlab, lo[w], size[w], r[w], &w0, &w1);
        if (!rc_grid_macro_any(macroOccupied, mres, k, u, w, mk, u0, u1, w0, w1)) continue;
        /* A slab box of at most 2 x 2 cells serves each of its slices (it holds their boxes):
         * fewer reductions for a few more cells. */
        const int slabBox = u1 - u0 <= 1 && w1 - w0 <= 1;
        for (int s = backwards ? s1 : s0; s >= s0 && s <= s1; s += step) {
            rc_grid_slab(lo[k], size[k], s, s, ok, ik, tn, tf, slackAbs, &t0, &t1);
            const int16 pending = inGrid & (t0 <= reach);
            /* No lane reaches beyond this slice, or every lane has its hit before it. */
            if (!any(pending & (t0 <= tf))) return tests;
            int16 in = pending & (t0 <= t1);
            if (!any(in)) continue;
            if (!slabBox) {
                rc_grid_lane_range(ou, du, t0, t1, in, lo[u], size[u], r[u], &u0, &u1);
                rc_grid_lane_range(ow, dw, t0, t1, in, lo[w], size[w], r[w], &w0, &w1);
            }
            uint cell[3];
            cell[k] = (uint)s;
            for (int cw = w0; cw <= w1; ++cw) {
                cell[w] = (uint)cw;
                for (int cu = u0; cu <= u1; ++cu) {
                    cell[u] = (uint)cu;
                    const uint c = cell[0] + res.x * (cell[1] + res.y * cell[2]);
                    *visits += as_uint16(in) & (uint16)(1);
                    const uint end = cellStart[c + 1];
                    for (uint j = cellStart[c]; j < end; ++j) {
                        const uint id = primIndex[j];
                        const RcTriangle tri = triangles[id];
                        const int16 lanes = in & (t0 <= reach);
                        tests += as_uint16(lanes) & (uint16)(1);
                        const int16 hit =
                            rc_accel_triangle16(p, lanes, tri.v0.xyz, tri.v1.xyz - tri.v0.xyz,
                                                tri.v2.xyz - tri.v0.xyz, id, bt, bp, bu, bv);
                        if (anyHit) {
                            *blocked |= hit;
                            reach = select(reach, (float16)(-INFINITY), hit);
                            in &= ~hit;
                            if (!any(in)) break;
                        } else {
                            reach = *bt;
                        }
                    }
                    if (!any(in)) break;
                }
                if (!any(in)) break;
            }
        }
    }
    return tests;
}

/* The coherent-packet walk's answers for rays [first, first + 16): nearest hits, or blocked
 * flags when anyHit. */
static inline void rc_grid_packet(const RcBvhPacket* p, int anyHit, uint first, uint n,
                                  __global const uint* cellStart, __global const uint* primIndex,
                                  __global const uchar* macroOccupied, float4 boxLo, float4 boxHi,
                                  float4 cellSize, uint4 res, __global const RcTriangle* triangles,
                                  __global RcHit* hits, __global uchar* blockedOut,
                                  __global uint* counters) {
    float16 bt = p->tmax, bu = (float16)(0.0f), bv = (float16)(0.0f);
    uint16 bp = (uint16)(RC_NO_HIT), visits = (uint16)(0);
    int16 blocked = (int16)(0);
    const uint16 tests =
        rc_grid_trace_packet(p, anyHit, cellStart, primIndex, macroOccupied, boxLo, boxHi, cellSize,
                             res, triangles, &bt, &bp, &bu, &bv, &blocked, &visits);
    rc_accel_store_packet(anyHit, first, n, bt, bp, bu, bv, blocked, tests, visits, hits,
                          blockedOut, counters);
}

/* The answers of rays [first, first + 16): nearest hits, or with anyHit blocked flags, and
 * their counters. A coherent packet walks the grid once, other rays one by one. */
static inline void rc_grid_answer(int anyHit, __global const RcRay* rays, uint first, uint n,
                                  __global const uint* cellStart, __global const uint* primIndex,
                                  __global const uchar* macroOccupied, float4 boxLo, float4 boxHi,
                                  float4 cellSize, uint4 res, __global const RcTriangle* triangles,
                                  __global const RcSphere* spheres,
                                  __global const RcQuadric* quadrics,
                                  __constant const RcRenderParams* params, __global RcHit* hits,
                                  __global uchar* blockedOut, __global uint* counters) {
    RcBvhPacket p;
    if (rc_accel_load_packet(rays, first, n, anyHit, boxLo, boxHi, params, &p)) {
        rc_grid_packet(&p, anyHit, first, n, cellStart, primIndex, macroOccupied, boxLo, boxHi,
                       cellSize, res, triangles, hits, blockedOut, counters);
        return;
    }
    for (uint i = first; i < min(first + RC_PACKET, n); ++i) {
        RcHit best = rc_no_hit(rays[i].direction.w);
        uint visits = 0;
        const uint tests =
            rc_grid_trace(rays[i], anyHit, cellStart, primIndex, boxLo, boxHi, cellSize, res,
                          triangles, spheres, quadrics, params, &best, &visits);
        rc_accel_store_ray(anyHit, i, n, best, tests, visits, hits, blockedOut, counters);
    }
}

/* One work-item per 16 rays rays[16 i, 16 i + 16). */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_intersect_grid(
    __global const RcRay* rays, uint n, __global const uint* cellStart,
    __global const uint* primIndex, __global const uchar* macroOccupied, float4 boxLo, float4 boxHi,
    float4 cellSize, uint4 res, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global RcHit* hits, __global uint* counters) {
    const uint first = get_global_id(0) * RC_PACKET;
    if (first >= n) return;
    rc_grid_answer(0, rays, first, n, cellStart, primIndex, macroOccupied, boxLo, boxHi, cellSize,
                   res, triangles, spheres, quadrics, params, hits, 0, counters);
}

/* Any hit before the light ends a ray's search; one work-item per 16 rays, as above. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_grid(
    __global const RcRay* rays, uint n, __global const uint* cellStart,
    __global const uint* primIndex, __global const uchar* macroOccupied, float4 boxLo, float4 boxHi,
    float4 cellSize, uint4 res, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global uchar* blocked, __global uint* counters) {
    const uint first = get_global_id(0) * RC_PACKET;
    if (first >= n) return;
    rc_grid_answer(1, rays, first, n, cellStart, primIndex, macroOccupied, boxLo, boxHi, cellSize,
                   res, triangles, spheres, quadrics, params, 0, blocked, counters);
}
