/* Ray queries over the leaves of the ray classification (classify/hierarchy.h). A leaf batch is
 * flat: leaves (ray and candidate ranges), rayIndex (the leaves' rays as indices into the
 * generation's ray buffer, which stays on the device), candidates (sorted by nearX per leaf).
 *
 * Three styles answer the same question and return the same hit (lower id wins ties; shadow
 * rays: the same blocked flag):
 * - scalar: one work-item per ray, one candidate at a time: the baseline;
 * - vertex (the thesis's MIMD vertex unit): one work-item per ray with its own control flow, the
 *   SIMD lanes over 16 candidates of its leaf (RcTriangleBlock16), stopping at the first block
 *   whose nearX lies beyond its current hit;
 * - fragment (the thesis's SIMD fragment unit): one work-item per packet of 16 rays of one leaf,
 *   the lanes over the rays, all testing the same candidate in lockstep with select instead of
 *   branches; the packet stops when every lane's hit is nearer than the next candidate.
 * Distance optimisation: a candidate whose box starts (nearX, along the face's main axis) beyond
 * the ray's current hit X cannot be nearer, and neither can any later one. */
#include "rc_types.h"
#include "intersect.cl"
#include "shade.cl"
#include "vec16.cl"

#pragma OPENCL FP_CONTRACT OFF

static inline float rc_face_component(float3 v, uint face) {
    const uint axis = face >> 1;
    const float c = axis == 0 ? v.x : (axis == 1 ? v.y : v.z);
    return (face & 1) ? -c : c;
}

/* The largest X a shadow ray's segment (tmin, tmax) reaches in the frame of its leaf's face:
 * its end, or its start when the classification took it from its far end, the light
 * (classify::CommonEnds); candidates whose box starts beyond it cannot block it. */
static inline float rc_segment_end_x(float3 o, float3 d, float tmin, float tmax, uint face) {
    const float dx = rc_face_component(d, face);
    return rc_face_component(o, face) + (dx > 0.0f ? tmax : tmin) * dx;
}

/* The miss of every ray in ids[0, n): rays the classification found can reach no primitive. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_write_misses(
    __global const uint* ids, uint n, __global RcHit* hits) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    hits[ids[i]] = rc_no_hit(INFINITY);
}

/* --- scalar ------------------------------------------------------------------------------- */

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

/* --- vertex style ------------------------------------------------------------------------- */

/* One work-item per block: the leaf's candidates [16 b, 16 b + 16) in SoA form. blockLeaf[b]
 * names the leaf, blockFirst[b] the block's first candidate within it. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_gather_blocks(
    __global const uint* blockLeaf, __global const uint* blockFirst, uint nBlocks,
    __global const RcLeaf* leaves, __global const RcCandidate* candidates,
    __global const RcTriangle* triangles, __constant const RcRenderParams* params,
    __global RcTriangleBlock16* blocks) {
    const uint b = get_global_id(0);
    if (b >= nBlocks) return;
    const RcLeaf leaf = leaves[blockLeaf[b]];
    const uint first = blockFirst[b];
    const uint count = min(16u, leaf.candCount - first);
    __global RcTriangleBlock16* out = blocks + b;
    uint other = 0;
    for (uint k = 0; k < 16; ++k) {
        float3 v0 = (float3)(0.0f), e1 = (float3)(0.0f), e2 = (float3)(0.0f);
        uint prim = RC_NO_HIT;
        if (k < count) {
            prim = candidates[leaf.candBegin + first + k].prim;
            if (prim < params->nTriangles) {
                v0 = triangles[prim].v0.xyz;
                e1 = triangles[prim].v1.xyz - v0;
                e2 = triangles[prim].v2.xyz - v0;
            } else {
                other |= 1u << k;
            }
        }
        out->v0x[k] = v0.x;
        out->v0y[k] = v0.y;
        out->v0z[k] = v0.z;
        out->e1x[k] = e1.x;
        out->e1y[k] = e1.y;
        out->e1z[k] = e1.z;
        out->e2x[k] = e2.x;
        out->e2y[k] = e2.y;
        out->e2z[k] = e2.z;
        out->prim[k] = prim;
    }
    out->otherMask = other;
    out->count = count;
    out->nearX = candidates[leaf.candBegin + first].nearX;
}

/* Moeller-Trumbore of one ray against the 16 triangle lanes of a block, the same operations as
 * rc_intersect_triangle lane by lane. Returns t per lane, +inf where a lane misses. */
static inline float16 rc_triangles16(float3 o, float3 d, float tmin, float tmax,
                                     __global const RcTriangleBlock16* blk, float16* uOut,
                                     float16* vOut) {
    const float16 e1x = vload16(0, blk->e1x), e1y = vload16(0, blk->e1y),
                  e1z = vload16(0, blk->e1z);
    const float16 e2x = vload16(0, blk->e2x), e2y = vload16(0, blk->e2y),
                  e2z = vload16(0, blk->e2z);
    /* pv = cross(d, e2) */
    const float16 pvx = d.y * e2z - e2y * d.z;
    const float16 pvy = d.z * e2x - e2z * d.x;
    const float16 pvz = d.x * e2y - e2x * d.y;
    const float16 det = e1x * pvx + e1y * pvy + e1z * pvz;
    const float16 invDet = 1.0f / det;
    const float16 tvx = o.x - vload16(0, blk->v0x);
    const float16 tvy = o.y - vload16(0, blk->v0y);
    const float16 tvz = o.z - vload16(0, blk->v0z);
    const float16 u = (tvx * pvx + tvy * pvy + tvz * pvz) * invDet;
    /* qv = cross(tv, e1) */
    const float16 qvx = tvy * e1z - e1y * tvz;
    const float16 qvy = tvz * e1x - e1z * tvx;
    const float16 qvz = tvx * e1y - e1x * tvy;
    const float16 v = (d.x * qvx + d.y * qvy + d.z * qvz) * invDet;
    const float16 t = (e2x * qvx + e2y * qvy + e2z * qvz) * invDet;
    const int16 ok = (det != 0.0f) & (u >= 0.0f) & (u <= 1.0f) & (v >= 0.0f) &
                     (u + v <= 1.0f) & (t > tmin) & (t < tmax);
    *uOut = u;
    *vOut = v;
    return select((float16)(INFINITY), t, ok);
}

static inline void rc_vertex_update(float16 t, float16 u, float16 v,
                                    __global const RcTriangleBlock16* blk, RcHit* best) {
    const float tMin16 = min(min(min(t.s0, t.s1), min(t.s2, t.s3)),
                             min(min(t.s4, t.s5), min(t.s6, t.s7)));
    const float tMin16b = min(min(min(t.s8, t.s9), min(t.sa, t.sb)),
                              min(min(t.sc, t.sd), min(t.se, t.sf)));
    if (!(min(tMin16, tMin16b) <= best->t)) return;
    float ts[16], us[16], vs[16];
    vstore16(t, 0, ts);
    vstore16(u, 0, us);
    vstore16(v, 0, vs);
    for (uint k = 0; k < 16; ++k) {
        const uint prim = blk->prim[k];
        if (ts[k] < best->t || (ts[k] == best->t && ts[k] != INFINITY && prim < best->prim)) {
            best->t = ts[k];
            best->prim = prim;
            best->u = us[k];
            best->v = vs[k];
        }
    }
}

/* The nearest hit of one ray over its leaf's blocks; *tested counts the candidates in the blocks
 * it went through. */
static inline RcHit rc_vertex_nearest(const RcRay* ray, RcLeaf leaf, uint firstBlock,
                                      __global const RcTriangleBlock16* blocks,
                                      __global const RcTriangle* triangles,
                                      __global const RcSphere* spheres,
                                      __global const RcQuadric* quadrics,
                                      __constant const RcRenderParams* params, uint* tested) {
    const float3 o = ray->origin.xyz, d = ray->direction.xyz;
    const float tmin = ray->origin.w, tmax = ray->direction.w;
    const float originX = rc_face_component(o, leaf.face);
    const float speed = fabs(rc_face_component(d, leaf.face));
    RcHit best = rc_no_hit(tmax);
    const uint nBlocks = (leaf.candCount + 15) / 16;
    uint b = 0;
    for (; b < nBlocks; ++b) {
        __global const RcTriangleBlock16* blk = blocks + firstBlock + b;
        if (best.prim != RC_NO_HIT && originX + best.t * speed < blk->nearX) break;
        /* A hit at exactly best.t may still win on its lower id. */
        const float bound = fmin(tmax, nextafter(best.t, INFINITY));
        float16 u, v;
        const float16 t = rc_triangles16(o, d, tmin, bound, blk, &u, &v);
        rc_vertex_update(t, u, v, blk, &best);
        for (uint other = blk->otherMask; other != 0; other &= other - 1) {
            const uint k = 31 - clz(other & -other);
            rc_intersect_primitive(blk->prim[k], o, d, tmin, tmax, triangles, spheres, quadrics,
                                   params->nTriangles, params->nSpheres, &best);
        }
    }
    if (best.prim == RC_NO_HIT) best.t = INFINITY;
    *tested = min(b * 16, leaf.candCount);
    return best;
}

/* The thesis's vertex unit whole: the work-item that found the hit shades it and writes its
 * shadow, reflection and refraction rays. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_query_vertex_shade(
    __global const RcRay* rays, __global const RcRayInfo* infos, __global const uint* rayIndex,
    __global const uint* rayLeaf, uint nSlots, __global const RcLeaf* leaves,
    __global const uint* leafFirstBlock, __global const RcTriangleBlock16* blocks,
    __global RcHit* hits, __global uint* tests, RC_SHADE_SCENE_PARAMS, RC_SHADE_OUT_PARAMS) {
    const uint slot = get_global_id(0);
    if (slot >= nSlots) return;
    const uint id = rayIndex[slot];
    const uint leafId = rayLeaf[slot];
    const RcRay ray = rays[id];
    uint tested;
    const RcHit hit = rc_vertex_nearest(&ray, leaves[leafId], leafFirstBlock[leafId], blocks,
                                        triangles, spheres, quadrics, params, &tested);
    hits[id] = hit;
    tests[slot] = tested;
    const RcRayInfo info = rc_ray_info(infos, id);
    rc_shade_ray(id, &ray, &info, hit, RC_SHADE_SCENE_ARGS, RC_SHADE_OUT_ARGS);
}

__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_vertex(
    __global const RcRay* rays, __global const uint* rayIndex, __global const uint* rayLeaf,
    uint nSlots, __global const RcLeaf* leaves, __global const uint* leafFirstBlock,
    __global const RcTriangleBlock16* blocks, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global uchar* blocked, __global uint* tests) {
    const uint slot = get_global_id(0);
    if (slot >= nSlots) return;
    const uint id = rayIndex[slot];
    const uint leafId = rayLeaf[slot];
    const RcLeaf leaf = leaves[leafId];
    const float3 o = rays[id].origin.xyz, d = rays[id].direction.xyz;
    const float tmin = rays[id].origin.w, tmax = rays[id].direction.w;
    const float endX = rc_segment_end_x(o, d, tmin, tmax, leaf.face);
    const uint first = leafFirstBlock[leafId];
    const uint nBlocks = (leaf.candCount + 15) / 16;
    uchar hit = 0;
    uint b = 0;
    for (; b < nBlocks && !hit; ++b) {
        __global const RcTriangleBlock16* blk = blocks + first + b;
        if (blk->nearX > endX) break;
        float16 u, v;
        const float16 t = rc_triangles16(o, d, tmin, tmax, blk, &u, &v);
        hit = any(t < INFINITY);
        for (uint other = blk->otherMask; other != 0 && !hit; other &= other - 1) {
            const uint k = 31 - clz(other & -other);
            RcHit h = rc_no_hit(tmax);
            hit = rc_intersect_primitive(blk->prim[k], o, d, tmin, tmax, triangles, spheres,
                                         quadrics, params->nTriangles, params->nSpheres, &h);
        }
    }
    blocked[id] = hit;
    tests[slot] = min(b * 16, leaf.candCount);
}

/* --- fragment style ----------------------------------------------------------------------- */

typedef struct RcLanes16 {
    float16 ox, oy, oz, dx, dy, dz, tmin, tmax;
    float16 x, dX, speed; /* the origins' X, the directions' component and its size along the
                            * leaf's face */
} RcLanes16;

/* The rays of a packet as lanes: the leaf's rays [first, first + 16), unused lanes repeating the
 * first ray (their results are not written); ids[k] is lane k's ray (RcRay: origin, w: tmin;
 * direction, w: tmax; shadow rays too). The rays are read as float4 into registers and
 * transposed there (RC_LANES16): lanes written one float at a time to private arrays and read
 * back as float16 cost half the fragment kernel's time on PoCL (the arrays become per-work-item
 * context memory). */
RC_SHADE_INLINE RcLanes16 rc_load_packet(__global const RcRay* rays, __global const uint* rayIndex,
                                         RcLeaf leaf, uint first, uint* ids) {
    const uint count = min(16u, leaf.rayCount - first);
    __global const uint* index = rayIndex + leaf.rayBegin + first;
    float4 o[16], d[16];
#pragma unroll
    for (uint k = 0; k < 16; ++k) {
        const uint id = index[k < count ? k : 0];
        ids[k] = id;
        o[k] = rays[id].origin;
        d[k] = rays[id].direction;
    }
    RcLanes16 l;
    l.ox = RC_LANES16(o, x);
    l.oy = RC_LANES16(o, y);
    l.oz = RC_LANES16(o, z);
    l.tmin = RC_LANES16(o, w);
    l.dx = RC_LANES16(d, x);
    l.dy = RC_LANES16(d, y);
    l.dz = RC_LANES16(d, z);
    l.tmax = RC_LANES16(d, w);
    const uint axis = leaf.face >> 1;
    const float sign = (leaf.face & 1) ? -1.0f : 1.0f;
    l.x = sign * (axis == 0 ? l.ox : (axis == 1 ? l.oy : l.oz));
    l.dX = sign * (axis == 0 ? l.dx : (axis == 1 ? l.dy : l.dz));
    l.speed = fabs(l.dX);
    return l;
}

/* Packet p's ray ids, *count of them; none past the last packet. */
RC_SHADE_INLINE __global const uint* rc_packet_ids(__global const uint* rayIndex,
                                                   __global const RcLeaf* leaves,
                                                   __global const uint* packetLeaf,
                                                   __global const uint* packetFirst, uint p,
                                                   uint nPackets, uint* count) {
    *count = 0;
    if (p >= nPackets) return rayIndex;
    const RcLeaf leaf = leaves[packetLeaf[p]];
    const uint first = packetFirst[p];
    *count = min(16u, leaf.rayCount - first);
    return rayIndex + leaf.rayBegin + first;
}

/* On a CPU device (PoCL compiles the kernels for the host's x86-64) the next work-items a thread
 * runs are the next packets: fetching packet p's rays while this one tests its candidates hides
 * the cache misses of its scattered ray loads. */
RC_SHADE_INLINE void rc_prefetch_packet(__global const RcRay* rays, __global const uint* rayIndex,
                                        __global const RcLeaf* leaves,
                                        __global const uint* packetLeaf,
                                        __global const uint* packetFirst, uint p, uint nPackets) {
#if defined(__x86_64__)
    uint count;
    __global const uint* ids =
        rc_packet_ids(rayIndex, leaves, packetLeaf, packetFirst, p, nPackets, &count);
    for (uint k = 0; k < count; ++k) __builtin_prefetch(rays + ids[k]);
#endif
}

/* Packet p's hit slots, fetched for writing: its answers go to scattered lines that would
 * otherwise be read in only when the packet writes them. */
RC_SHADE_INLINE void rc_prefetch_hits(__global RcHit* hits, __global const uint* rayIndex,
                                      __global const RcLeaf* leaves,
                                      __global const uint* packetLeaf,
                                      __global const uint* packetFirst, uint p, uint nPackets) {
#if defined(__x86_64__)
    uint count;
    __global const uint* ids =
        rc_packet_ids(rayIndex, leaves, packetLeaf, packetFirst, p, nPackets, &count);
    for (uint k = 0; k < count; ++k) __builtin_prefetch(hits + ids[k], 1);
#endif
}

/* rc_intersect_triangle for 16 rays against one triangle, the same operations lane by lane:
 * the lanes that hit inside (tmin, tmax), with t, u and v. */
RC_SHADE_INLINE int16 rc_packet_triangle(const RcLanes16* L, RcTriangle tri, float16* t,
                                         float16* u, float16* v) {
    const float16 Ox = L->ox, Oy = L->oy, Oz = L->oz, Dx = L->dx, Dy = L->dy, Dz = L->dz;
    const float3 p0 = tri.v0.xyz;
    const float3 e1 = tri.v1.xyz - p0;
    const float3 e2 = tri.v2.xyz - p0;
    const float16 pvx = Dy * e2.z - e2.y * Dz;
    const float16 pvy = Dz * e2.x - e2.z * Dx;
    const float16 pvz = Dx * e2.y - e2.x * Dy;
    const float16 det = e1.x * pvx + e1.y * pvy + e1.z * pvz;
    const float16 invDet = 1.0f / det;
    const float16 tvx = Ox - p0.x, tvy = Oy - p0.y, tvz = Oz - p0.z;
    *u = (tvx * pvx + tvy * pvy + tvz * pvz) * invDet;
    const float16 qvx = tvy * e1.z - e1.y * tvz;
    const float16 qvy = tvz * e1.x - e1.z * tvx;
    const float16 qvz = tvx * e1.y - e1.x * tvy;
    *v = (Dx * qvx + Dy * qvy + Dz * qvz) * invDet;
    *t = (e2.x * qvx + e2.y * qvy + e2.z * qvz) * invDet;
    return (det != 0.0f) & (*u >= 0.0f) & (*u <= 1.0f) & (*v >= 0.0f) & (*u + *v <= 1.0f) &
           (*t > L->tmin) & (*t < L->tmax);
}

/* rc_intersect_sphere for 16 rays against one sphere, the same operations lane by lane, below
 * each lane's own bound: the lanes that hit inside (tmin, tmax), with t. */
RC_SHADE_INLINE int16 rc_packet_sphere(const RcLanes16* L, float4 centerRadius, float16 tmax,
                                       float16* t) {
    const float16 Dx = L->dx, Dy = L->dy, Dz = L->dz;
    const float16 fx = L->ox - centerRadius.x, fy = L->oy - centerRadius.y,
                  fz = L->oz - centerRadius.z;
    const float r = centerRadius.w;
    const float16 a = Dx * Dx + Dy * Dy + Dz * Dz;
    const float16 b = -(fx * Dx + fy * Dy + fz * Dz);
    const float16 ba = b / a;
    const float16 lx = fx + ba * Dx, ly = fy + ba * Dy, lz = fz + ba * Dz;
    const float16 disc = a * (r * r - (lx * lx + ly * ly + lz * lz));
    const float16 c = (fx * fx + fy * fy + fz * fz) - r * r;
    const float16 q = b + copysign(sqrt(disc), b);
    const float16 r0 = select(c / q, (float16)(0.0f), q == 0.0f);
    const float16 r1 = q / a;
    const int16 swap = r0 > r1;
    const float16 t0 = select(r0, r1, swap), t1 = select(r1, r0, swap);
    const int16 in0 = (t0 > L->tmin) & (t0 < tmax);
    const int16 in1 = (t1 > L->tmin) & (t1 < tmax);
    *t = select(t1, t0, in0);
    return ~(disc < 0.0f) & (in0 | in1);
}

/* Whether root r of each lane counts for rc_intersect_quadric: inside (tmin, tmax), its point in
 * the clip box [lo, hi]. */
RC_SHADE_INLINE int16 rc_packet_root_counts(const RcLanes16* L, float16 r, float16 tmax, float3 lo,
                                            float3 hi) {
    const float16 x = L->ox + r * L->dx, y = L->oy + r * L->dy, z = L->oz + r * L->dz;
    return (r > L->tmin) & (r < tmax) & (x >= lo.x) & (x <= hi.x) & (y >= lo.y) & (y <= hi.y) &
           (z >= lo.z) & (z <= hi.z);
}

/* rc_intersect_quadric for 16 rays against one quadric, the same operations lane by lane, below
 * each lane's own bound: the lanes that hit inside (tmin, tmax) within the clip box, with t. A
 * lane of the linear case (a = 0) takes its one root as both of the pair. */
RC_SHADE_INLINE int16 rc_packet_quadric(const RcLanes16* L, __global const RcQuadric* q,
                                        float16 tmax, float16* t) {
    const float4 c0 = q->c0, c1 = q->c1, c2 = q->c2;
    const float16 Ox = L->ox, Oy = L->oy, Oz = L->oz, Dx = L->dx, Dy = L->dy, Dz = L->dz;
    const float16 a = c0.x * Dx * Dx + c0.y * Dy * Dy + c0.z * Dz * Dz + c0.w * Dx * Dy +
                      c1.x * Dx * Dz + c1.y * Dy * Dz;
    const float16 b = 2.0f * (c0.x * Ox * Dx + c0.y * Oy * Dy + c0.z * Oz * Dz) +
                      c0.w * (Ox * Dy + Oy * Dx) + c1.x * (Ox * Dz + Oz * Dx) +
                      c1.y * (Oy * Dz + Oz * Dy) + c1.z * Dx + c1.w * Dy + c2.x * Dz;
    const float16 c = c0.x * Ox * Ox + c0.y * Oy * Oy + c0.z * Oz * Oz + c0.w * Ox * Oy +
                      c1.x * Ox * Oz + c1.y * Oy * Oz + c1.z * Ox + c1.w * Oy + c2.x * Oz + c2.y;
    const int16 linear = a == 0.0f;
    const float16 disc = b * b - 4.0f * a * c;
    const float16 qq = -0.5f * (b + copysign(sqrt(disc), b));
    const float16 q0 = qq / a;
    const float16 q1 = select(c / qq, q0, qq == 0.0f);
    const int16 swap = q0 > q1;
    const float16 root = -c / b;
    const float16 r0 = select(select(q0, q1, swap), root, linear);
    const float16 r1 = select(select(q1, q0, swap), root, linear);
    const int16 valid = select(~(disc < 0.0f), b != 0.0f, linear);
    const float3 lo = q->boxMin.xyz, hi = q->boxMax.xyz;
    const int16 in0 = rc_packet_root_counts(L, r0, tmax, lo, hi);
    const int16 in1 = rc_packet_root_counts(L, r1, tmax, lo, hi);
    *t = select(r1, r0, in0);
    return valid & (in0 | in1);
}

#include "patch_packet.cl"

/* The nearest hit of each lane of L over `leaf`'s candidates, into best*; returns the
 * candidates tested. `trianglesOnly` is a constant at both call sites: the loop of a scene of
 * triangles alone then holds no sphere, quadric or patch set-up, which the compiler otherwise
 * hoists out of the loop, per packet, and whose values crowd the loop's registers. */
RC_SHADE_INLINE uint rc_fragment_nearest(const RcLanes16* L, RcLeaf leaf,
                                         __global const RcCandidate* candidates,
                                         __global const RcTriangle* triangles,
                                         __global const RcSphere* spheres,
                                         __global const RcQuadric* quadrics, uint nT, uint nS,
                                         const bool trianglesOnly, float16* bestT,
                                         float16* bestU, float16* bestV, uint16* bestPrim) {
    uint c = 0;
    for (; c < leaf.candCount; ++c) {
        const RcCandidate cand = candidates[leaf.candBegin + c];
        /* Every lane done: its hit is strictly nearer than this candidate's box. */
        const int16 done =
            (*bestPrim != (uint16)(RC_NO_HIT)) & (L->x + *bestT * L->speed < cand.nearX);
        if (all(done)) break;
        const uint prim = cand.prim;
        float16 t, u = 0.0f, v = 0.0f;
        int16 inside;
        if (trianglesOnly || prim < nT) {
            inside = rc_packet_triangle(L, triangles[prim], &t, &u, &v);
        } else {
            /* rc_intersect_primitive's bound: a hit at exactly bestT may still win on its id. */
            const float16 bound = fmin(L->tmax, nextafter(*bestT, (float16)(INFINITY)));
            if (prim < nT + nS) {
                inside = rc_packet_sphere(L, spheres[prim - nT].centerRadius, bound, &t);
            } else if (quadrics[prim - nT - nS].kind == RC_ANALYTIC_PATCH_BOX) {
                inside = rc_packet_patch(L, (__global const float4*)quadrics,
                                         (__global const RcPatchBox*)(quadrics + (prim - nT - nS)),
                                         bound, &t, &u, &v);
            } else {
                inside = rc_packet_quadric(L, quadrics + (prim - nT - nS), bound, &t);
            }
        }
        /* Nearer, or equally near with a lower id: the depth test with the id tie-break. */
        const int16 better =
            inside & ((t < *bestT) | ((t == *bestT) & ((uint16)(prim) < *bestPrim)));
        *bestT = select(*bestT, t, better);
        *bestU = select(*bestU, u, better);
        *bestV = select(*bestV, v, better);
        *bestPrim = select(*bestPrim, (uint16)(prim), as_uint16(better));
    }
    return c;
}

/* One work-item per packet: packetLeaf[p] and packetFirst[p] (the packet's first ray within its
 * leaf); the packet holds min(16, rayCount - first) rays. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_query_fragment(
    __global const RcRay* rays, __global const uint* rayIndex, __global const uint* packetLeaf,
    __global const uint* packetFirst, uint nPackets, __global const RcLeaf* leaves,
    __global const RcCandidate* candidates, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global RcHit* hits, __global uint* tests) {
    const uint p = get_global_id(0);
    if (p >= nPackets) return;
    const RcLeaf leaf = leaves[packetLeaf[p]];
    const uint count = min(16u, leaf.rayCount - packetFirst[p]);
    uint ids[16];
    const RcLanes16 L = rc_load_packet(rays, rayIndex, leaf, packetFirst[p], ids);
    /* Rays two packets ahead: one packet's tests did not hide the whole fetch. */
    rc_prefetch_packet(rays, rayIndex, leaves, packetLeaf, packetFirst, p + 2, nPackets);
    rc_prefetch_hits(hits, rayIndex, leaves, packetLeaf, packetFirst, p + 1, nPackets);
    float16 bestT = L.tmax, bestU = 0.0f, bestV = 0.0f;
    uint16 bestPrim = (uint16)(RC_NO_HIT);
    const uint nT = params->nTriangles, nS = params->nSpheres;
    const uint c =
        nS == 0 && params->nQuadrics == 0
            ? rc_fragment_nearest(&L, leaf, candidates, triangles, spheres, quadrics, nT, nS, true,
                                  &bestT, &bestU, &bestV, &bestPrim)
            : rc_fragment_nearest(&L, leaf, candidates, triangles, spheres, quadrics, nT, nS,
                                  false, &bestT, &bestU, &bestV, &bestPrim);
    float bt[16], bu[16], bv[16];
    uint bp[16];
    vstore16(bestT, 0, bt);
    vstore16(bestU, 0, bu);
    vstore16(bestV, 0, bv);
    vstore16(bestPrim, 0, bp);
    for (uint k = 0; k < count; ++k) {
        RcHit h;
        h.prim = bp[k];
        h.t = bp[k] == RC_NO_HIT ? INFINITY : bt[k];
        h.u = bu[k];
        h.v = bv[k];
        hits[ids[k]] = h;
    }
    tests[p] = c * count;
}

/* Any hit before each lane's tmax (the light), 16 shadow rays of one leaf in lockstep: a lane is
 * done once blocked or once the candidates start beyond its end X; the packet stops when every
 * lane is done. The triangle, sphere and quadric tests are those of intersect.cl, lane by
 * lane. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_fragment(
    __global const RcRay* rays, __global const uint* rayIndex, __global const uint* packetLeaf,
    __global const uint* packetFirst, uint nPackets, __global const RcLeaf* leaves,
    __global const RcCandidate* candidates, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global uchar* blocked, __global uint* tests) {
    const uint p = get_global_id(0);
    if (p >= nPackets) return;
    const RcLeaf leaf = leaves[packetLeaf[p]];
    const uint count = min(16u, leaf.rayCount - packetFirst[p]);
    uint ids[16];
    const RcLanes16 L = rc_load_packet(rays, rayIndex, leaf, packetFirst[p], ids);
    rc_prefetch_packet(rays, rayIndex, leaves, packetLeaf, packetFirst, p + 1, nPackets);
    const float16 endX = L.x + select(L.tmin, L.tmax, L.dX > 0.0f) * L.dX;
    int16 hit = (int16)(0);
    const uint nT = params->nTriangles, nS = params->nSpheres;
    uint c = 0;
    for (; c < leaf.candCount; ++c) {
        const RcCandidate cand = candidates[leaf.candBegin + c];
        /* Lists are sorted by nearX: a lane that has passed its end stays past it. */
        const int16 beyond = cand.nearX > endX;
        if (all(hit | beyond)) break;
        const uint prim = cand.prim;
        if (prim < nT) {
            float16 t, u, v;
            const int16 inside = rc_packet_triangle(&L,
                                                    triangles[prim], &t, &u, &v);
            hit |= ~beyond & inside;
        } else if (prim < nT + nS) {
            float16 t;
            hit |= ~beyond & rc_packet_sphere(&L, spheres[prim - nT].centerRadius, L.tmax, &t);
        } else {
            __global const RcQuadric* q = quadrics + (prim - nT - nS);
            float16 t, u, v;
            hit |= ~beyond & (q->kind == RC_ANALYTIC_PATCH_BOX
                                  ? rc_packet_patch(&L, (__global const float4*)quadrics,
                                                    (__global const RcPatchBox*)q, L.tmax, &t,
                                                    &u, &v)
                                  : rc_packet_quadric(&L, q, L.tmax, &t));
        }
    }
    int h[16];
    vstore16(hit, 0, h);
    for (uint k = 0; k < count; ++k) blocked[ids[k]] = h[k] != 0 ? 1 : 0;
    tests[p] = c * count;
}
