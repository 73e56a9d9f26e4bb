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
 * The scalar and vertex styles' kernels lie in classified_scalar.cl and classified_vertex.cl.
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

/* Each triangle as its first vertex and two edges (p0, v1 - p0, v2 - p0, each a float4 whose w
 * is unused): rc_packet_triangle's subtractions, done once per triangle by the same device
 * arithmetic, so the edges are bit for bit those the test would compute. The fragment loops over
 * a scene of triangles alone then read each component from memory as a broadcast operand, where
 * the edges computed in registers took a shuffle per component and candidate on the pipes the
 * loops' multiplies need. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_triangle_edges(
    __global const RcTriangle* triangles, uint n, __global float4* edges) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    const float4 p0 = triangles[i].v0;
    edges[3 * i] = p0;
    edges[3 * i + 1] = triangles[i].v1 - p0;
    edges[3 * i + 2] = triangles[i].v2 - p0;
}

/* --- fragment style ----------------------------------------------------------------------- */

typedef struct RcLanes16 {
    float16 ox, oy, oz, dx, dy, dz, tmin, tmax;
    float16 x, dX, speed; /* the origins' X, the directions' component and its size along the
                            * leaf's face */
} RcLanes16;

/* The shuffles of rc_transpose_pairs, a pair per round: from two vectors, the positions whose
 * bit 2 (1, 0) is clear (_LO) or set (_HI), the first vector's and the second's in turn; that
 * bit of the position then tells which vector the element came from. */
#define RC_BIT2_LO 0, 1, 2, 3, 16, 17, 18, 19, 8, 9, 10, 11, 24, 25, 26, 27
#define RC_BIT2_HI 4, 5, 6, 7, 20, 21, 22, 23, 12, 13, 14, 15, 28, 29, 30, 31
#define RC_BIT1_LO 0, 1, 16, 17, 4, 5, 20, 21, 8, 9, 24, 25, 12, 13, 28, 29
#define RC_BIT1_HI 2, 3, 18, 19, 6, 7, 22, 23, 10, 11, 26, 27, 14, 15, 30, 31
#define RC_BIT0_LO 0, 16, 2, 18, 4, 20, 6, 22, 8, 24, 10, 26, 12, 28, 14, 30
#define RC_BIT0_HI 1, 17, 3, 19, 5, 21, 7, 23, 9, 25, 11, 27, 13, 29, 15, 31

/* The 8 fields of 16 rays as lanes, from v[j] = rays a_j and b_j whole (position 8 r + f: field
 * f of a_j for r = 0, of b_j for r = 1): lane j holds a_j, lane 8 + j b_j. Three rounds, each
 * exchanging one bit of the vector index with one bit of the position. */
RC_SHADE_INLINE void rc_transpose_pairs(float16* v) {
    float16 w[8];
#pragma unroll
    for (uint k = 0; k < 4; ++k) {
        w[k] = RC_SHUFFLE2(v[k], v[k + 4], RC_BIT2_LO);
        w[k + 4] = RC_SHUFFLE2(v[k], v[k + 4], RC_BIT2_HI);
    }
#pragma unroll
    for (uint h = 0; h < 8; h += 4) {
#pragma unroll
        for (uint k = 0; k < 2; ++k) {
            v[h + k] = RC_SHUFFLE2(w[h + k], w[h + k + 2], RC_BIT1_LO);
            v[h + k + 2] = RC_SHUFFLE2(w[h + k], w[h + k + 2], RC_BIT1_HI);
        }
    }
#pragma unroll
    for (uint k = 0; k < 8; k += 2) {
        w[k] = RC_SHUFFLE2(v[k], v[k + 1], RC_BIT0_LO);
        w[k + 1] = RC_SHUFFLE2(v[k], v[k + 1], RC_BIT0_HI);
    }
#pragma unroll
    for (uint k = 0; k < 8; ++k) v[k] = w[k];
}

/* The rays of a packet as lanes: the leaf's rays [first, first + 16) (RcRay: origin, w: tmin;
 * direction, w: tmax; shadow rays too); ids[k] is lane k's ray. Each float16 holds two rays'
 * whole records and rc_transpose_pairs makes them lanes. Eye rays come in runs of pixels: a
 * full packet whose rays pair up in consecutive slots (2j, 2j + 1) reads each pair as one
 * float16, its lanes in the order of the pairs' first rays then of their second ones. Other
 * packets (shadow rays, scattered) read rays j and 8 + j as two 32-byte halves of one float16,
 * the lanes in slot order, unused lanes repeating the first ray (their results are not
 * written); a full packet's ids come from its one vector load, as ids chosen lane by lane
 * compile to gathers. Rays read as float4s and built into lanes element by element take
 * several times the shuffles: LLVM folds shuffles of float4 loads back into that build. */
RC_SHADE_INLINE RcLanes16 rc_load_packet(__global const RcRay* rays, __global const uint* rayIndex,
                                         RcLeaf leaf, uint first, uint* ids) {
    const uint count = min(16u, leaf.rayCount - first);
    __global const uint* index = rayIndex + leaf.rayBegin + first;
    uint16 id16 = (uint16)(0);
    if (count == 16) id16 = vload16(0, index);
    const uint8 a = id16.even, b = id16.odd;
    float16 v[8];
    if (count == 16 && all(b == a + 1u)) {
        vstore16((uint16)(a, b), 0, ids);
#pragma unroll
        for (uint j = 0; j < 8; ++j) v[j] = vload16(0, (__global const float*)(rays + ids[j]));
        rc_transpose_pairs(v);
    } else {
        if (count == 16) {
            vstore16(id16, 0, ids);
        } else {
#pragma unroll
            for (uint k = 0; k < 16; ++k) ids[k] = index[k < count ? k : 0];
        }
#pragma unroll
        for (uint j = 0; j < 8; ++j) {
            v[j] = (float16)(vload8(0, (__global const float*)(rays + ids[j])),
                             vload8(0, (__global const float*)(rays + ids[j + 8])));
        }
        rc_transpose_pairs(v);
    }
    RcLanes16 l;
    l.ox = v[0];
    l.oy = v[1];
    l.oz = v[2];
    l.tmin = v[3];
    l.dx = v[4];
    l.dy = v[5];
    l.dz = v[6];
    l.tmax = v[7];
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

/* How many candidates ahead of the one tested the triangle loops fetch a triangle. */
#define RC_TRIANGLE_PREFETCH 4

/* Candidate c + RC_TRIANGLE_PREFETCH's triangle of `leaf` in rc_triangle_edges' array, fetched
 * while candidate c is tested: a leaf's candidates lie scattered over the scene's triangles, and
 * the test waits on each triangle's load otherwise. */
RC_SHADE_INLINE void rc_prefetch_triangle(__global const RcCandidate* candidates,
                                          __global const float4* edges, RcLeaf leaf, uint c) {
#if defined(__x86_64__)
    if (c + RC_TRIANGLE_PREFETCH < leaf.candCount) {
        __builtin_prefetch(edges + 3 * candidates[leaf.candBegin + c + RC_TRIANGLE_PREFETCH].prim);
    }
#endif
}

/* rc_intersect_triangle for 16 rays against the triangle of first vertex p0 and edges e1, e2,
 * the same operations lane by lane: the lanes that hit inside (tmin, tmax), with t, u and v. */
RC_SHADE_INLINE int16 rc_packet_triangle_edges(const RcLanes16* L, float3 p0, float3 e1, float3 e2,
                                               float16* t, float16* u, float16* v) {
    const float16 Ox = L->ox, Oy = L->oy, Oz = L->oz, Dx = L->dx, Dy = L->dy, Dz = L->dz;
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

/* rc_packet_triangle_edges of triangle `tri`. */
RC_SHADE_INLINE int16 rc_packet_triangle(const RcLanes16* L, RcTriangle tri, float16* t,
                                         float16* u, float16* v) {
    const float3 p0 = tri.v0.xyz;
    return rc_packet_triangle_edges(L, p0, tri.v1.xyz - p0, tri.v2.xyz - p0, t, u, v);
}

/* rc_packet_triangle_edges of triangle `prim` of rc_triangle_edges' array, its components read
 * one by one from memory. */
RC_SHADE_INLINE int16 rc_packet_edges(const RcLanes16* L, __global const float* edges, uint prim,
                                      float16* t, float16* u, float16* v) {
    __global const float* e = edges + 12 * prim;
    return rc_packet_triangle_edges(L, (float3)(e[0], e[1], e[2]), (float3)(e[4], e[5], e[6]),
                                    (float3)(e[8], e[9], e[10]), t, u, v);
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
                                         __global const float4* edges,
                                         __global const RcSphere* spheres,
                                         __global const RcQuadric* quadrics, uint nT, uint nS,
                                         const bool trianglesOnly, float16* bestT,
                                         float16* bestU, float16* bestV, uint16* bestPrim) {
    /* Each lane's hit's X, +infinity while it has none: one compare with a candidate's nearX then
     * tells whether the lane is done (its hit strictly nearer than the candidate's box), a mask
     * the exit tests at once, where the lanes without a hit took a second compare. */
    float16 reachX = select((float16)(INFINITY), L->x + *bestT * L->speed,
                            *bestPrim != (uint16)(RC_NO_HIT));
    uint c = 0;
    for (; c < leaf.candCount; ++c) {
        const RcCandidate cand = candidates[leaf.candBegin + c];
        if (rc_all16(reachX < cand.nearX)) break;
        const uint prim = cand.prim;
        float16 t, u = 0.0f, v = 0.0f;
        int16 inside;
        if (trianglesOnly) {
            rc_prefetch_triangle(candidates, edges, leaf, c);
            inside = rc_packet_edges(L, (__global const float*)edges, prim, &t, &u, &v);
        } else if (prim < nT) {
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
        reachX = select(reachX, L->x + *bestT * L->speed, better);
    }
    return c;
}

#define RC_PAIRS_LO 0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23
#define RC_PAIRS_HI 8, 24, 9, 25, 10, 26, 11, 27, 12, 28, 13, 29, 14, 30, 15, 31
#define RC_QUADS_LO 0, 1, 16, 17, 2, 3, 18, 19, 4, 5, 20, 21, 6, 7, 22, 23
#define RC_QUADS_HI 8, 9, 24, 25, 10, 11, 26, 27, 12, 13, 28, 29, 14, 15, 30, 31

/* Lane k's hit (RcHit: t, prim, u, v from the lanes of t, prim's bits, u and v) to
 * hits[ids[k]], k < count: the four lane vectors transposed into four vectors of four hits each
 * by two rounds of shuffles, and each hit stored as a float4 (element by element, the stores
 * went through a private array). */
RC_SHADE_INLINE void rc_store_hits(__global RcHit* hits, const uint* ids, uint count, float16 t,
                                   float16 prim, float16 u, float16 v) {
    const float16 tp0 = RC_SHUFFLE2(t, prim, RC_PAIRS_LO), tp1 = RC_SHUFFLE2(t, prim, RC_PAIRS_HI);
    const float16 uv0 = RC_SHUFFLE2(u, v, RC_PAIRS_LO), uv1 = RC_SHUFFLE2(u, v, RC_PAIRS_HI);
    /* h[q]: the hits of lanes 4 q to 4 q + 3. */
    const float16 h[4] = {RC_SHUFFLE2(tp0, uv0, RC_QUADS_LO), RC_SHUFFLE2(tp0, uv0, RC_QUADS_HI),
                          RC_SHUFFLE2(tp1, uv1, RC_QUADS_LO), RC_SHUFFLE2(tp1, uv1, RC_QUADS_HI)};
#pragma unroll
    for (uint q = 0; q < 4; ++q) {
        __global float* at0 = (__global float*)(hits + ids[4 * q]);
        __global float* at1 = (__global float*)(hits + ids[4 * q + 1]);
        __global float* at2 = (__global float*)(hits + ids[4 * q + 2]);
        __global float* at3 = (__global float*)(hits + ids[4 * q + 3]);
        if (4 * q < count) vstore4(h[q].s0123, 0, at0);
        if (4 * q + 1 < count) vstore4(h[q].s4567, 0, at1);
        if (4 * q + 2 < count) vstore4(h[q].s89ab, 0, at2);
        if (4 * q + 3 < count) vstore4(h[q].scdef, 0, at3);
    }
}

/* One work-item per packet: packetLeaf[p] and packetFirst[p] (the packet's first ray within its
 * leaf); the packet holds min(16, rayCount - first) rays. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_query_fragment(
    __global const RcRay* rays, __global const uint* rayIndex, __global const uint* packetLeaf,
    __global const uint* packetFirst, uint nPackets, __global const RcLeaf* leaves,
    __global const RcCandidate* candidates, __global const RcTriangle* triangles,
    __global const float4* edges, __global const RcSphere* spheres,
    __global const RcQuadric* quadrics, __constant const RcRenderParams* params,
    __global RcHit* hits, __global uint* tests) {
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
            ? rc_fragment_nearest(&L, leaf, candidates, triangles, edges, spheres, quadrics, nT,
                                  nS, true, &bestT, &bestU, &bestV, &bestPrim)
            : rc_fragment_nearest(&L, leaf, candidates, triangles, edges, spheres, quadrics, nT,
                                  nS, false, &bestT, &bestU, &bestV, &bestPrim);
    const float16 t = select(bestT, (float16)(INFINITY), bestPrim == (uint16)(RC_NO_HIT));
    rc_store_hits(hits, ids, count, t, as_float16(bestPrim), bestU, bestV);
    tests[p] = c * count;
}

/* Whether each lane of L hits any of `leaf`'s candidates before its tmax, ORed into *hit; returns
 * the candidates tested. A lane is done once blocked or once the candidates start beyond its end
 * X (`endX`); the packet stops when every lane is done. `trianglesOnly` is a constant at both
 * call sites, as in rc_fragment_nearest: the compiler otherwise hoists the sphere, quadric and
 * patch set-up out of the loop, a square root and divisions per packet. */
RC_SHADE_INLINE uint rc_fragment_any(const RcLanes16* L, RcLeaf leaf,
                                     __global const RcCandidate* candidates,
                                     __global const RcTriangle* triangles,
                                     __global const float4* edges,
                                     __global const RcSphere* spheres,
                                     __global const RcQuadric* quadrics, uint nT, uint nS,
                                     const bool trianglesOnly, float16 endX, int16* hit) {
    /* endX, and -infinity once the lane is blocked: one compare with a candidate's nearX (a
     * finite number) then tells both ways a lane is done, a mask the exit tests at once, where
     * ORing the blocked lanes' vector in took a chain of shuffles and tests. */
    float16 liveEndX = endX;
    uint c = 0;
    for (; c < leaf.candCount; ++c) {
        const RcCandidate cand = candidates[leaf.candBegin + c];
        if (rc_all16(cand.nearX > liveEndX)) break;
        /* Lists are sorted by nearX: a lane that has passed its end stays past it. */
        const int16 beyond = cand.nearX > endX;
        const uint prim = cand.prim;
        int16 blocks;
        if (trianglesOnly) {
            rc_prefetch_triangle(candidates, edges, leaf, c);
            float16 t, u, v;
            blocks = rc_packet_edges(L, (__global const float*)edges, prim, &t, &u, &v);
        } else if (prim < nT) {
            float16 t, u, v;
            blocks = rc_packet_triangle(L, triangles[prim], &t, &u, &v);
        } else if (prim < nT + nS) {
            float16 t;
            blocks = rc_packet_sphere(L, spheres[prim - nT].centerRadius, L->tmax, &t);
        } else {
            __global const RcQuadric* q = quadrics + (prim - nT - nS);
            float16 t, u, v;
            blocks = q->kind == RC_ANALYTIC_PATCH_BOX
                         ? rc_packet_patch(L, (__global const float4*)quadrics,
                                           (__global const RcPatchBox*)q, L->tmax, &t, &u, &v)
                         : rc_packet_quadric(L, q, L->tmax, &t);
        }
        blocks &= ~beyond;
        *hit |= blocks;
        liveEndX = select(liveEndX, (float16)(-INFINITY), blocks);
    }
    return c;
}

/* Any hit before each lane's tmax (the light), 16 shadow rays of one leaf in lockstep
 * (rc_fragment_any). The triangle, sphere and quadric tests are those of intersect.cl, lane by
 * lane. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_fragment(
    __global const RcRay* rays, __global const uint* rayIndex, __global const uint* packetLeaf,
    __global const uint* packetFirst, uint nPackets, __global const RcLeaf* leaves,
    __global const RcCandidate* candidates, __global const RcTriangle* triangles,
    __global const float4* edges, __global const RcSphere* spheres,
    __global const RcQuadric* quadrics, __constant const RcRenderParams* params,
    __global uchar* blocked, __global uint* tests) {
    const uint p = get_global_id(0);
    if (p >= nPackets) return;
    const RcLeaf leaf = leaves[packetLeaf[p]];
    const uint count = min(16u, leaf.rayCount - packetFirst[p]);
    uint ids[16];
    const RcLanes16 L = rc_load_packet(rays, rayIndex, leaf, packetFirst[p], ids);
    /* Two packets ahead, as rc_query_fragment: one packet's tests did not hide the fetch. */
    rc_prefetch_packet(rays, rayIndex, leaves, packetLeaf, packetFirst, p + 2, nPackets);
    const float16 endX = L.x + select(L.tmin, L.tmax, L.dX > 0.0f) * L.dX;
    int16 hit = (int16)(0);
    const uint nT = params->nTriangles, nS = params->nSpheres;
    /* Only a scene of triangles alone: a candidate c + RC_TRIANGLE_PREFETCH may be another
     * primitive, whose id does not index the triangles. */
    const uint c = nS == 0 && params->nQuadrics == 0
                       ? rc_fragment_any(&L, leaf, candidates, triangles, edges, spheres,
                                         quadrics, nT, nS, true, endX, &hit)
                       : rc_fragment_any(&L, leaf, candidates, triangles, edges, spheres,
                                         quadrics, nT, nS, false, endX, &hit);
    const uchar16 flags = convert_uchar16(hit & 1);
#pragma unroll
    for (uint k = 0; k < 16; ++k) {
        if (k < count) blocked[ids[k]] = flags[k];
    }
    tests[p] = c * count;
}
