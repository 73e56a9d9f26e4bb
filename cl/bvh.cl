/* Ray queries through the 8-wide bounding volume hierarchy (include/rayclass/bvh/bvh.h): one ray
 * per work-item, a per-ray stack, one float8 slab test for all children of a node, nearest child
 * first, a leaf's triangles eight at a time from its run (bvh/leaf_blocks.h) with the
 * operations of the scalar routine, its other primitives through the routines every other query
 * uses (intersect.cl, lower id wins ties), so the hits equal brute force's exactly. Node
 * boxes are padded on the host and the slab test's far distance is widened by 2 gamma(3) (Ize
 * 2013), so rounding never culls a primitive the routines would hit. tests[i] counts primitive
 * tests (in a packet, the tests of every leaf the packet visits while ray i is active). */
#include "intersect.cl"
#include "rc_types.h"
#include "vec16.cl"

#pragma OPENCL FP_CONTRACT OFF

/* bvh::kStackEntries: the host keeps every walk within it. */
#define RC_BVH_STACK 128

/* min and max as one instruction each: the slab test below never meets a NaN. */
static inline float8 rc_min8(float8 a, float8 b) { return select(b, a, a < b); }
static inline float8 rc_max8(float8 a, float8 b) { return select(b, a, a > b); }

/* 1 / d, with a zero component replaced by a huge finite value of its sign: then no slab distance
 * is 0 * infinity (NaN), and min and max can be plain selects. The boxes' padding keeps every
 * primitive strictly inside its slabs, so a ray parallel to a slab can reach the primitives only
 * from inside it (tests/render/bvh_query_test.cpp). */
static inline float3 rc_bvh_inverse(float3 d) {
    const float3 inv = (float3)(1.0f) / d;
    return select(inv, copysign((float3)(1e30f), inv), isinf(inv));
}

/* A node's boxes as one array of planes (RcBvh8Node's loX, loY, loZ, hiX, hiY, hiZ, eight floats
 * each): axis a's lower planes from 8 a on, its upper ones RC_BVH8_UPPER further. */
#define RC_BVH8_UPPER 24
static inline __global const float* rc_bvh_planes(__global const RcBvh8Node* nd) {
    return (__global const float*)nd;
}

/* Where in rc_bvh_planes the planes of axis a start through which rays enter the boxes: the
 * lower ones for rays that head up the axis (`up`, a positive inverse direction). Boxes hold
 * lo <= hi and rounding is monotonic, so their distance is the min of the two planes' distances
 * (equal ones at most differ in the sign of a zero, which no comparison sees): the side is
 * chosen once per ray or packet, instead of a min and a max per node or a choice per child. */
static inline int rc_bvh_near_planes(int up, int a) { return 8 * a + (up ? 0 : RC_BVH8_UPPER); }

/* The other planes of the axis, where the ray leaves the boxes. */
static inline int rc_bvh_far_planes(int nearPlanes) {
    return nearPlanes < RC_BVH8_UPPER ? nearPlanes + RC_BVH8_UPPER : nearPlanes - RC_BVH8_UPPER;
}

/* Eight lanes of array `a` of a leaf run of `stride` primitives from `lane0` on, zero in the
 * lanes beyond the run (live clear): those hold the next array's words, ids among them, which as
 * floats are denormals, slow to compute with. */
static inline float8 rc_leaf_load8(__global const float* lane0, uint stride, uint a, int8 live) {
    return select((float8)(0.0f), vload8(0, lane0 + a * stride), live);
}

/* The ids of a leaf run's eight lanes from `lane0` on, RC_NO_HIT beyond the run. */
static inline uint8 rc_leaf_prims8(__global const float* lane0, uint stride, int8 live) {
    return select((uint8)(RC_NO_HIT),
                  as_uint8(vload8(0, lane0 + (RC_BVH_LEAF_ARRAYS - 1) * stride)), live);
}

/* The id of lane k of a leaf run of `stride` primitives from `lane0` on. */
static inline uint rc_leaf_prim(__global const float* lane0, uint stride, uint k) {
    return as_uint(lane0[(RC_BVH_LEAF_ARRAYS - 1) * stride + k]);
}

/* Moeller-Trumbore of one ray against eight lanes of a leaf run (lanes beyond it zero edges,
 * which the test rejects), the same operations as rc_intersect_triangle lane by lane. Returns t
 * per lane, +inf where a lane misses or its t is not below `bound`. */
static inline float8 rc_bvh_triangles8(float3 o, float3 d, float tmin, float bound,
                                       __global const float* lane0, uint stride, int8 live,
                                       float8* uOut, float8* vOut) {
    const float8 e1x = rc_leaf_load8(lane0, stride, 3, live);
    const float8 e1y = rc_leaf_load8(lane0, stride, 4, live);
    const float8 e1z = rc_leaf_load8(lane0, stride, 5, live);
    const float8 e2x = rc_leaf_load8(lane0, stride, 6, live);
    const float8 e2y = rc_leaf_load8(lane0, stride, 7, live);
    const float8 e2z = rc_leaf_load8(lane0, stride, 8, live);
    /* pv = cross(d, e2) */
    const float8 pvx = d.y * e2z - e2y * d.z;
    const float8 pvy = d.z * e2x - e2z * d.x;
    const float8 pvz = d.x * e2y - e2x * d.y;
    const float8 det = e1x * pvx + e1y * pvy + e1z * pvz;
    const float8 invDet = 1.0f / det;
    const float8 tvx = o.x - rc_leaf_load8(lane0, stride, 0, live);
    const float8 tvy = o.y - rc_leaf_load8(lane0, stride, 1, live);
    const float8 tvz = o.z - rc_leaf_load8(lane0, stride, 2, live);
    const float8 u = (tvx * pvx + tvy * pvy + tvz * pvz) * invDet;
    /* qv = cross(tv, e1) */
    const float8 qvx = tvy * e1z - e1y * tvz;
    const float8 qvy = tvz * e1x - e1z * tvx;
    const float8 qvz = tvx * e1y - e1x * tvy;
    const float8 v = (d.x * qvx + d.y * qvy + d.z * qvz) * invDet;
    const float8 t = (e2x * qvx + e2y * qvy + e2z * qvz) * invDet;
    const int8 ok = (det != 0.0f) & (u >= 0.0f) & (u <= 1.0f) & (v >= 0.0f) & (u + v <= 1.0f) &
                    (t > tmin) & (t < bound);
    *uOut = u;
    *vOut = v;
    return select((float8)(INFINITY), t, ok);
}

/* The leaf one primitive at a time, for the watertight triangle test, which has no eight-lane
 * form: the same answer and count as rc_bvh_leaf. */
static inline int rc_bvh_leaf_scalar(uint count, __global const float* leaf, float3 o, float3 d,
                                     float tmin, float tmax, int anyHit,
                                     __global const RcTriangle* triangles,
                                     __global const RcSphere* spheres,
                                     __global const RcQuadric* quadrics, uint nT, uint nS,
                                     RcHit* best, uint* tests) {
    for (uint k = 0; k < count; ++k) {
        ++*tests;
        if (rc_intersect_primitive(rc_leaf_prim(leaf, count, k), o, d, tmin, tmax, triangles,
                                   spheres, quadrics, nT, nS, best) &&
            anyHit)
            return 1;
    }
    return 0;
}

/* The leaf whose `count` primitives fill the run at `leaf`, with the lower-id tie-break.
 * Returns 1 when anyHit and a primitive was hit; *tests counts the primitives tested, as if one
 * at a time in lane order up to an any-hit (the count rc_intersect_primitive walks would give). */
static inline int rc_bvh_leaf(uint count, __global const float* leaf, float3 o, float3 d,
                              float tmin, float tmax, int anyHit,
                              __global const RcTriangle* triangles,
                              __global const RcSphere* spheres, __global const RcQuadric* quadrics,
                              uint nT, uint nS, RcHit* best, uint* tests) {
    for (uint first = 0; first < count; first += 8) {
        __global const float* lane0 = leaf + first;
        const uint lanes = min(8u, count - first);
        const int8 live = (int8)(0, 1, 2, 3, 4, 5, 6, 7) < (int8)(lanes);
        float8 u8, v8;
        const float8 t8 = rc_bvh_triangles8(o, d, tmin, fmin(tmax, nextafter(best->t, INFINITY)),
                                            lane0, count, live, &u8, &v8);
        const uint8 prim8 = rc_leaf_prims8(lane0, count, live);
        /* Spheres and quadrics take the scalar routines. */
        const int8 other8 = (prim8 >= (uint8)(nT)) & (prim8 != (uint8)(RC_NO_HIT));
        float ts[8];
        vstore8(t8, 0, ts);
        if (anyHit) {
            for (uint k = 0; k < lanes; ++k) {
                const uint prim = rc_leaf_prim(lane0, count, k);
                ++*tests;
                if (prim >= nT ? rc_intersect_primitive(prim, o, d, tmin, tmax, triangles, spheres,
                                                        quadrics, nT, nS, best)
                               : ts[k] != INFINITY) {
                    best->prim = prim;
                    return 1;
                }
            }
            continue;
        }
        *tests += lanes;
        const float4 m4 = fmin(t8.lo, t8.hi);
        const float2 m2 = fmin(m4.lo, m4.hi);
        if (fmin(m2.x, m2.y) <= best->t) {
            float us[8], vs[8];
            vstore8(u8, 0, us);
            vstore8(v8, 0, vs);
            for (uint k = 0; k < lanes; ++k) {
                const uint prim = rc_leaf_prim(lane0, count, k);
                if (ts[k] < best->t ||
                    (ts[k] == best->t && ts[k] != INFINITY && prim < best->prim)) {
                    best->t = ts[k];
                    best->prim = prim;
                    best->u = us[k];
                    best->v = vs[k];
                }
            }
        }
        if (any(other8)) {
            for (uint k = 0; k < lanes; ++k) {
                const uint prim = rc_leaf_prim(lane0, count, k);
                if (prim >= nT)
                    rc_intersect_primitive(prim, o, d, tmin, tmax, triangles, spheres, quadrics, nT,
                                           nS, best);
            }
        }
    }
    return 0;
}

#ifdef RC_WATERTIGHT
#define RC_BVH_LEAF rc_bvh_leaf_scalar
#else
#define RC_BVH_LEAF rc_bvh_leaf
#endif

/* Walks the tree; with anyHit it returns at the first hit. Returns the primitive tests done. */
static inline uint rc_bvh_trace(float3 o, float3 d, float tmin, float tmax, int anyHit,
                                __global const RcBvh8Node* nodes, __global const float* leaves,
                                __global const RcTriangle* triangles,
                                __global const RcSphere* spheres,
                                __global const RcQuadric* quadrics, uint nT, uint nS, RcHit* best) {
    const float8 ox = (float8)(o.x), oy = (float8)(o.y), oz = (float8)(o.z);
    const float3 inv = rc_bvh_inverse(d);
    const float8 ix = (float8)(inv.x), iy = (float8)(inv.y), iz = (float8)(inv.z);
    const int nearX = rc_bvh_near_planes(!signbit(inv.x), 0);
    const int nearY = rc_bvh_near_planes(!signbit(inv.y), 1);
    const int nearZ = rc_bvh_near_planes(!signbit(inv.z), 2);
    const int farX = rc_bvh_far_planes(nearX), farY = rc_bvh_far_planes(nearY),
              farZ = rc_bvh_far_planes(nearZ);
    const int8 laneBit = (int8)(1, 2, 4, 8, 16, 32, 64, 128);
    /* Entries wait with the distance at which the ray enters them: one beyond the nearest hit
     * found since is dropped when popped. */
    uint stackRef[RC_BVH_STACK];
    float stackT[RC_BVH_STACK];
    int sp = 0;
    uint ref = 0, tests = 0;
    for (;;) {
        if (ref & RC_BVH8_LEAF) {
            const uint count = ((ref & ~RC_BVH8_LEAF) >> RC_BVH8_COUNT_SHIFT) + 1;
            if (RC_BVH_LEAF(count, leaves + (ref & RC_BVH8_FIRST_MASK) * RC_BVH_LEAF_ALIGN, o, d,
                            tmin, tmax, anyHit, triangles, spheres, quadrics, nT, nS, best, &tests))
                return tests;
        } else {
            __global const RcBvh8Node* nd = nodes + ref;
            __global const float* planes = rc_bvh_planes(nd);
            const float8 nx = (vload8(0, planes + nearX) - ox) * ix;
            const float8 ny = (vload8(0, planes + nearY) - oy) * iy;
            const float8 nz = (vload8(0, planes + nearZ) - oz) * iz;
            const float8 fx = (vload8(0, planes + farX) - ox) * ix;
            const float8 fy = (vload8(0, planes + farY) - oy) * iy;
            const float8 fz = (vload8(0, planes + farZ) - oz) * iz;
            const float8 tn = rc_max8(rc_max8(nx, ny), rc_max8(nz, (float8)(tmin)));
            const float8 tf = rc_min8(rc_min8(fx, fy), fz) * 1.0000004f;
            /* A box entered exactly at best->t may still hold a lower id at that distance. */
            const int8 enters = (tn <= rc_min8(tf, (float8)(fmin(tmax, best->t)))) &
                                (laneBit < (int8)(1 << nd->nChildren)) & laneBit;
            const int4 m4 = enters.lo | enters.hi;
            const int2 m2 = m4.lo | m4.hi;
            int mask = m2.x | m2.y;
            if (mask != 0) {
                float near[8];
                vstore8(tn, 0, near);
                /* The entered children, nearest first (insertion sort of at most eight), or
                 * in lane order when any hit ends the walk. */
                uint r[8];
                float t[8];
                int k = 0;
                for (; mask != 0; mask &= mask - 1) {
                    const int c = popcount((mask & -mask) - 1);
                    int j = k++;
                    for (; !anyHit && j > 0 && t[j - 1] > near[c]; --j) {
                        t[j] = t[j - 1];
                        r[j] = r[j - 1];
                    }
                    t[j] = near[c];
                    r[j] = nd->child[c];
                }
                for (int j = k - 1; j > 0; --j) {
                    stackRef[sp] = r[j];
                    stackT[sp++] = t[j];
                }
                ref = r[0];
                continue;
            }
        }
        for (;;) {
            if (sp == 0) return tests;
            --sp;
            if (stackT[sp] <= best->t) break;
        }
        ref = stackRef[sp];
    }
}

/* --- packets of 16 rays -------------------------------------------------------------------
 * A work-item answers 16 consecutive rays. Where they are coherent (their directions share an
 * octant and lie within a narrow cone) it walks the tree once for all of them, the lanes of every
 * float16 over the rays: a node's child is entered when any lane enters it, each lane with the
 * single-ray walk's slab test and bounds, and a leaf's triangles are tested one at a time against
 * all lanes with rc_intersect_triangle's operations, lane by lane the same nearest hit and
 * tie-break. Neighbouring rays (eye rays of a row, the rays they spawn, their shadow rays) mostly
 * visit the same nodes, so the packet reads each node and triangle once for 16 rays. Other
 * packets, and scenes with spheres, quadrics or the watertight test, take the single-ray walk ray
 * by ray. */
#define RC_PACKET 16

static inline float16 rc_min16(float16 a, float16 b) { return select(b, a, a < b); }
static inline float16 rc_max16(float16 a, float16 b) { return select(b, a, a > b); }

/* The reductions of vec16.cl on eight lanes, for the halves' walks. */
static inline int rc_any8(int8 m) {
#ifdef RC_HAVE_REDUCE_MASK
    return __builtin_reduce_or(m < 0) != 0;
#else
    const int4 m4 = m.lo | m.hi;
    const int2 m2 = m4.lo | m4.hi;
    return (m2.x | m2.y) < 0;
#endif
}
static inline float rc_hmin8_ordered(float8 a) {
    const float4 m4 = select(a.hi, a.lo, a.lo < a.hi);
    const float2 m2 = select(m4.hi, m4.lo, m4.lo < m4.hi);
    return m2.x < m2.y ? m2.x : m2.y;
}
static inline float rc_hmax8_ordered(float8 a) {
    const float4 m4 = select(a.hi, a.lo, a.lo > a.hi);
    const float2 m2 = select(m4.hi, m4.lo, m4.lo > m4.hi);
    return m2.x > m2.y ? m2.x : m2.y;
}
static inline float rc_active_min8(float8 a, int8 active) {
    const float8 m8 = select((float8)(INFINITY), a, active);
    const float4 m4 = fmin(m8.lo, m8.hi);
    const float2 m2 = fmin(m4.lo, m4.hi);
    return fmin(m2.x, m2.y);
}
static inline float rc_active_max8(float8 a, int8 active) {
    const float8 m8 = select((float8)(-INFINITY), a, active);
    const float4 m4 = fmax(m8.lo, m8.hi);
    const float2 m2 = fmax(m4.lo, m4.hi);
    return fmax(m2.x, m2.y);
}

/* Rays as intervals, for one slab test of a node's eight boxes that culls a box only when no
 * ray can enter it: along each axis the points the distances are taken from within [lo, hi] and
 * the inverse directions within [iLo, iHi]. Rounding to nearest is monotonic, so the slab test's
 * own operations on the intervals' ends bound every ray's distances; an axis whose inverse
 * directions differ in sign bounds nothing. */
typedef struct RcBvhSlabs {
    float nearP[3], farP[3]; /* the points the entry and the exit distances are taken from */
    float iLo[3], iHi[3];
    int positive[3], bounded[3];
    int nearPlanes[3], farPlanes[3]; /* the boxes' sides they are taken to, in rc_bvh_planes */
} RcBvhSlabs;

static inline void rc_slabs_axis(float lo, float hi, float iLo, float iHi, int a, RcBvhSlabs* s) {
    s->iLo[a] = iLo;
    s->iHi[a] = iHi;
    s->positive[a] = iLo > 0.0f;
    s->bounded[a] = s->positive[a] || iHi < 0.0f;
    s->nearP[a] = s->positive[a] ? hi : lo;
    s->farP[a] = s->positive[a] ? lo : hi;
    s->nearPlanes[a] = rc_bvh_near_planes(s->positive[a], a);
    s->farPlanes[a] = rc_bvh_far_planes(s->nearPlanes[a]);
}

/* Whether every axis bounds the distances (the inverse directions in one octant). */
static inline int rc_slabs_one_octant(const RcBvhSlabs* s) {
    return s->bounded[0] && s->bounded[1] && s->bounded[2];
}

/* The least entry and the largest exit distance over the intervals' rays through the slabs
 * of one axis of nd's eight boxes, folded into *tn and *tf: only the sides the intervals enter
 * and leave by are loaded. The walks call it per axis: the three calls wrapped in one more
 * function made both walks slower on PoCL. */
static inline void rc_slabs_test(const RcBvhSlabs* s, int a, __global const RcBvh8Node* nd,
                                 float8* tn, float8* tf) {
    if (!s->bounded[a]) return;
    __global const float* planes = rc_bvh_planes(nd);
    const float8 n = vload8(0, planes + s->nearPlanes[a]) - s->nearP[a];
    const float8 f = vload8(0, planes + s->farPlanes[a]) - s->farP[a];
    *tn = rc_max8(*tn, n * select((float8)(s->iHi[a]), (float8)(s->iLo[a]), n >= 0.0f));
    *tf = rc_min8(*tf, f * select((float8)(s->iLo[a]), (float8)(s->iHi[a]), f >= 0.0f));
}

/* The packet walk at 16 lanes (RcBvhPacket, rc_bvh_trace_packet, ...) and at eight
 * (RcBvhPacket8, rc_bvh_trace_packet8, ...). The halves of eight lanes drop stack entries lane
 * by lane: their lanes spread, so an entry often holds for a few of them only; a coherent
 * packet's lanes share their entries, and its 16-lane entries cost more to keep than they cull. */
#define RC_W 16
#define RC_W_NAME(name) name
#define RC_W_LANE_CULL 0
#include "bvh_packet.inc.cl"
#undef RC_W
#undef RC_W_NAME
#undef RC_W_LANE_CULL
#define RC_W 8
#define RC_W_NAME(name) name##8
#define RC_W_LANE_CULL 1
#include "bvh_packet.inc.cl"
#undef RC_W
#undef RC_W_NAME
#undef RC_W_LANE_CULL

/* The packet's nearest hits (bt, bp, bu, bv) as the answers of rays [first, first + 16) below
 * n, a lane without a hit as t = inf. Lane k answers ray order[first + k] where order is given
 * (a sorted batch), else ray first + k. */
static inline void rc_packet_store_hits(uint first, uint n, float16 bt, uint16 bp, float16 bu,
                                        float16 bv, __global const uint* order,
                                        __global RcHit* hits) {
    float ts[RC_PACKET], us[RC_PACKET], vs[RC_PACKET];
    uint ps[RC_PACKET];
    vstore16(bt, 0, ts);
    vstore16(bu, 0, us);
    vstore16(bv, 0, vs);
    vstore16(bp, 0, ps);
    for (uint k = 0; k < RC_PACKET && first + k < n; ++k) {
        RcHit h;
        h.t = ps[k] == RC_NO_HIT ? INFINITY : ts[k];
        h.prim = ps[k];
        h.u = us[k];
        h.v = vs[k];
        hits[order ? order[first + k] : first + k] = h;
    }
}

/* Per-lane counts as out[ray], the rays as in rc_packet_store_hits. */
static inline void rc_packet_store_counts(uint first, uint n, uint16 counts,
                                          __global const uint* order, __global uint* out) {
    uint cs[RC_PACKET];
    vstore16(counts, 0, cs);
    for (uint k = 0; k < RC_PACKET && first + k < n; ++k)
        out[order ? order[first + k] : first + k] = cs[k];
}

/* The lanes that found a hit as blocked flags, the rays as in rc_packet_store_hits. */
static inline void rc_packet_store_blocked(uint first, uint n, int16 blocked,
                                           __global const uint* order, __global uchar* out) {
    int bs[RC_PACKET];
    vstore16(blocked, 0, bs);
    for (uint k = 0; k < RC_PACKET && first + k < n; ++k)
        out[order ? order[first + k] : first + k] = bs[k] != 0;
}

/* The largest spread of a packet's origins that walks as one, squared: a 32nd of the diagonal
 * of the root's children's boxes. Rays from scattered points share few nodes even when their
 * directions agree (shadow rays toward one light after several bounces). */
static inline float rc_bvh_max_spread2(__global const RcBvh8Node* root) {
    float3 lo = (float3)(INFINITY), hi = (float3)(-INFINITY);
    for (uint c = 0; c < root->nChildren; ++c) {
        lo = fmin(lo, (float3)(root->loX[c], root->loY[c], root->loZ[c]));
        hi = fmax(hi, (float3)(root->hiX[c], root->hiY[c], root->hiZ[c]));
    }
    const float3 e = (hi - lo) * (1.0f / 32.0f);
    return dot(e, e);
}

/* The active lanes whose directions lie within the cone about d of squared cosine cos2, their
 * squared lengths len2. */
static inline int16 rc_packet_within(const RcBvhPacket* p, float16 len2, float3 d, float cos2) {
    const float16 dd = p->dx * d.x + p->dy * d.y + p->dz * d.z;
    return p->active & (dd > 0.0f) & (dd * dd > cos2 * len2 * dot(d, d));
}

/* The packet's rays from rays[first, first + 16) (rays[order[first + k]] where order is given),
 * lanes beyond n inactive, and lanes with tmax == 0 (empty shadow slots) inactive when
 * skipEmpty. Returns whether the packet is coherent enough to walk as one: every active
 * direction in the first active one's octant and within about 18 degrees of it (cos > 0.95),
 * the origins' box's diagonal squared at most maxSpread2. */
static inline int rc_bvh_load_packet(__global const RcRay* rays, __global const uint* order,
                                     uint first, uint n, int skipEmpty, float maxSpread2,
                                     RcBvhPacket* p) {
    /* Rays read as float4 and transposed in registers: lanes written one float at a time to
     * private arrays go through memory on PoCL (see rc_load_packet, classified.cl). */
    float4 o[RC_PACKET], d[RC_PACKET];
#pragma unroll
    for (uint k = 0; k < RC_PACKET; ++k) {
        const uint j = first + k < n ? first + k : first;
        const uint i = order ? order[j] : j;
        o[k] = rays[i].origin;
        d[k] = rays[i].direction;
    }
    const int16 inRange =
        (int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15) < (int16)(n - first);
    p->ox = select((float16)(0.0f), RC_LANES16(o, x), inRange);
    p->oy = select((float16)(0.0f), RC_LANES16(o, y), inRange);
    p->oz = select((float16)(0.0f), RC_LANES16(o, z), inRange);
    p->tmin = select((float16)(0.0f), RC_LANES16(o, w), inRange);
    p->dx = select((float16)(1.0f), RC_LANES16(d, x), inRange);
    p->dy = select((float16)(1.0f), RC_LANES16(d, y), inRange);
    p->dz = select((float16)(1.0f), RC_LANES16(d, z), inRange);
    p->tmax = select((float16)(0.0f), RC_LANES16(d, w), inRange);
    p->active = inRange & (skipEmpty ? p->tmax != 0.0f : (int16)(-1));
    /* the first active lane's direction */
    float3 d0 = (float3)(0.0f);
    int lead = 0;
#pragma unroll
    for (int k = RC_PACKET - 1; k >= 0; --k) {
        const int act = first + k < n && (!skipEmpty || d[k].w != 0.0f);
        d0 = act ? d[k].xyz : d0;
        lead |= act;
    }
    const float16 len2 = p->dx * p->dx + p->dy * p->dy + p->dz * p->dz;
    const int16 octant = ((as_int16(p->dx) ^ as_int(d0.x)) | (as_int16(p->dy) ^ as_int(d0.y)) |
                          (as_int16(p->dz) ^ as_int(d0.z))) >= 0;
    const int16 near = octant & rc_packet_within(p, len2, d0, 0.9025f);
    const float3 lo = (float3)(rc_active_min16(p->ox, p->active), rc_active_min16(p->oy, p->active),
                               rc_active_min16(p->oz, p->active));
    const float3 hi = (float3)(rc_active_max16(p->ox, p->active), rc_active_max16(p->oy, p->active),
                               rc_active_max16(p->oz, p->active));
    const float3 spread = hi - lo;
    const int coherent = !lead || (!any(p->active & ~near) && dot(spread, spread) <= maxSpread2);
    /* rc_bvh_inverse lane by lane */
    const float16 invX = 1.0f / p->dx, invY = 1.0f / p->dy, invZ = 1.0f / p->dz;
    p->ix = select(invX, copysign((float16)(1e30f), invX), isinf(invX));
    p->iy = select(invY, copysign((float16)(1e30f), invY), isinf(invY));
    p->iz = select(invZ, copysign((float16)(1e30f), invZ), isinf(invZ));
    return coherent;
}

/* --- nearest-hit packets walked as two halves of eight lanes ----------------------------------
 * A bundled packet's lanes share fewer nodes than a coherent one's: walked as one, each lane rides
 * along into the nodes and leaves of the other fifteen. Its halves, walked one after the other,
 * visit fewer per lane; on cores that split a 16-lane operation into two of eight lanes (Zen 4)
 * a half costs about half the arithmetic of the whole packet. A half walks as
 * rc_bvh_trace_packet8, the nearest-hit walk of bvh_packet.inc.cl at eight lanes, so its lanes
 * find the hits of the whole packet's walk (and of the single-ray walk).
 */

/* Lanes 8 * upper .. 8 * upper + 7 of p. */
static inline RcBvhPacket8 rc_packet_half(const RcBvhPacket* p, int upper) {
    RcBvhPacket8 h;
#define RC_HALF(f) h.f = upper ? p->f.hi : p->f.lo
    RC_HALF(ox), RC_HALF(oy), RC_HALF(oz), RC_HALF(dx), RC_HALF(dy), RC_HALF(dz);
    RC_HALF(ix), RC_HALF(iy), RC_HALF(iz), RC_HALF(tmin), RC_HALF(tmax), RC_HALF(active);
#undef RC_HALF
    return h;
}

/* The nearest hits of p's lanes by its two halves' walks. */
static inline uint16 rc_bvh_trace_halves(const RcBvhPacket* p, __global const RcBvh8Node* nodes,
                                         __global const float* leaves, float16* bt, uint16* bp,
                                         float16* bu, float16* bv) {
    float8 t[2], u[2], v[2];
    uint8 prim[2], tests[2];
    for (int h = 0; h < 2; ++h) {
        const RcBvhPacket8 q = rc_packet_half(p, h);
        t[h] = q.tmax;
        u[h] = v[h] = (float8)(0.0f);
        prim[h] = (uint8)(RC_NO_HIT);
        tests[h] = (uint8)(0);
        int8 blocked = (int8)(0);
        if (rc_any8(q.active))
            tests[h] =
                rc_bvh_trace_packet8(&q, 0, nodes, leaves, &t[h], &prim[h], &u[h], &v[h], &blocked);
    }
    *bt = (float16)(t[0], t[1]);
    *bp = (uint16)(prim[0], prim[1]);
    *bu = (float16)(u[0], u[1]);
    *bv = (float16)(v[0], v[1]);
    return (uint16)(tests[0], tests[1]);
}

/* --- shadow packets as one beam ------------------------------------------------------------
 * Shadow rays toward a point light all end there: walked backwards from their ends they leave
 * (nearly) one point, and a coherent packet of them is a narrow beam. One interval slab test of
 * the whole beam against a node's eight boxes then stands for sixteen per-lane tests: s is the
 * distance along the reversed lanes (D = -d) from their ends S = o + tmax d, and the beam holds
 * every S within [sLo, sHi] (padded for the rounding of S) and every 1 / D within [iLo, iHi]
 * (one sign per axis, the packet's octant). Only a leaf is tested lane by lane, with the
 * single-ray walk's slab test, before its triangles; the triangles take the packet's exact
 * test, so the blocked flags are those of the per-lane walk. */
typedef struct RcBvhBeam {
    RcBvhSlabs slabs; /* the ends S and the inverses of D */
    float reach;      /* the longest reversed segment */
    float spread2;    /* the squared diagonal of the ends' box */
} RcBvhBeam;

/* The beam of one axis: the lanes' origins o, directions d and inverse directions inv along it. */
static inline void rc_beam_axis(const RcBvhPacket* p, float16 o, float16 d, float16 inv, int a,
                                RcBvhBeam* b) {
    const float16 end = o + p->tmax * d;
    const float16 size = fabs(o) + 2.0f * fabs(p->tmax * d);
    const float pad = 1e-5f * rc_active_max16(size, p->active);
    const float endLo = rc_active_min16(end, p->active), endHi = rc_active_max16(end, p->active);
    b->spread2 += (endHi - endLo) * (endHi - endLo);
    rc_slabs_axis(endLo - pad, endHi + pad, rc_active_min16(-inv, p->active),
                  rc_active_max16(-inv, p->active), a, &b->slabs);
}

static inline RcBvhBeam rc_bvh_beam(const RcBvhPacket* p) {
    RcBvhBeam b;
    b.spread2 = 0.0f;
    rc_beam_axis(p, p->ox, p->dx, p->ix, 0, &b);
    rc_beam_axis(p, p->oy, p->dy, p->iy, 1, &b);
    rc_beam_axis(p, p->oz, p->dz, p->iz, 2, &b);
    b.reach = rc_active_max16(p->tmax - p->tmin, p->active) * 1.0000004f;
    return b;
}

/* The lanes of the packet that enter child c of nd. */
static inline int16 rc_packet_enters(const RcBvhPacket* p, const RcPacketPlanes* q,
                                     __global const RcBvh8Node* nd, uint c, int16 active) {
    float16 tn, tf;
    rc_packet_child(p, q, nd, c, &tn, &tf);
    return active & (tn <= rc_min16(tf, p->tmax));
}

/* The packet's triangles of one leaf against its active lanes: the lanes they block join
 * *blocked and leave active. Returns the tests per lane. */
static inline uint16 rc_packet_leaf_occluded(const RcBvhPacket* p, uint ref,
                                             __global const float* leaves, int16* active,
                                             int16* blocked) {
    const uint count = ((ref & ~RC_BVH8_LEAF) >> RC_BVH8_COUNT_SHIFT) + 1;
    __global const float* leaf = leaves + (ref & RC_BVH8_FIRST_MASK) * RC_BVH_LEAF_ALIGN;
    uint16 tests = (uint16)(0);
    for (uint k = 0; k < count && rc_any16(*active); ++k) {
        tests += as_uint16(*active) & (uint16)(1);
        float16 t, u, v;
        const int16 hit = *active & rc_bvh_packet_triangle(p, leaf, count, k, &t, &u, &v);
        *blocked |= hit;
        *active &= ~hit;
    }
    return tests;
}

/* Walks the tree once for a packet of shadow rays as a beam: the lanes that found a blocker in
 * *blocked. Returns primitive tests per lane. */
static inline uint16 rc_bvh_occlude_beam(const RcBvhPacket* p, const RcBvhBeam* beam,
                                         __global const RcBvh8Node* nodes,
                                         __global const float* leaves, int16* blocked) {
    const int8 laneBit = (int8)(1, 2, 4, 8, 16, 32, 64, 128);
    uint stack[RC_BVH_STACK];
    int sp = 0;
    uint ref = 0;
    uint16 tests = (uint16)(0);
    int16 active = p->active;
    /* The beam runs the lanes reversed: their own inverse directions have the other signs. */
    const RcPacketPlanes planes =
        rc_packet_planes(p, !beam->slabs.positive[0], !beam->slabs.positive[1],
                         !beam->slabs.positive[2], rc_slabs_one_octant(&beam->slabs));
    for (;;) {
        if (ref & RC_BVH8_LEAF) {
            tests += rc_packet_leaf_occluded(p, ref, leaves, &active, blocked);
            if (!rc_any16(active)) return tests;
        } else {
            __global const RcBvh8Node* nd = nodes + ref;
            float8 tn = (float8)(0.0f), tf = (float8)(beam->reach);
            rc_slabs_test(&beam->slabs, 0, nd, &tn, &tf);
            rc_slabs_test(&beam->slabs, 1, nd, &tn, &tf);
            rc_slabs_test(&beam->slabs, 2, nd, &tn, &tf);
            const int8 enters =
                (tn <= tf * 1.0000004f) & (laneBit < (int8)(1 << nd->nChildren)) & laneBit;
            const int4 m4 = enters.lo | enters.hi;
            const int2 m2 = m4.lo | m4.hi;
            uint r[8];
            int k = 0;
            for (int mask = m2.x | m2.y; mask != 0; mask &= mask - 1) {
                const int c = popcount((mask & -mask) - 1);
                const uint child = nd->child[c];
                /* A leaf costs its triangles: only when a lane reaches its box. */
                if (!(child & RC_BVH8_LEAF) ||
                    rc_any16(rc_packet_enters(p, &planes, nd, c, active)))
                    r[k++] = child;
            }
            if (k > 0) {
                for (int j = k - 1; j > 0; --j) stack[sp++] = r[j];
                ref = r[0];
                continue;
            }
        }
        if (sp == 0) return tests;
        ref = stack[--sp];
    }
}

/* Whether packets may walk the tree: triangles only (at least one), tested as
 * rc_intersect_triangle tests. */
static inline int rc_packets_allowed(__constant const RcRenderParams* params) {
#ifdef RC_WATERTIGHT
    return 0;
#else
    return params->nTriangles > 0 && params->nSpheres + params->nQuadrics == 0;
#endif
}

/* The packet's answers: nearest hits, or with anyHit blocked flags; the rays as in
 * rc_packet_store_hits. */
static inline void rc_packet_store_answers(int anyHit, uint first, uint n, float16 bt, uint16 bp,
                                           float16 bu, float16 bv, int16 blocked,
                                           __global const uint* order, __global RcHit* hits,
                                           __global uchar* blockedOut) {
    if (anyHit)
        rc_packet_store_blocked(first, n, blocked, order, blockedOut);
    else
        rc_packet_store_hits(first, n, bt, bp, bu, bv, order, hits);
}

/* Whether a single ray needs a walk: not in a scene without primitives, nor, when anyHit, an
 * empty shadow slot (tmax 0), which nothing can block. */
static inline int rc_ray_walks(int anyHit, float tmax, __constant const RcRenderParams* params) {
    return params->nTriangles + params->nSpheres + params->nQuadrics > 0 &&
           !(anyHit && tmax == 0.0f);
}

/* A single ray's answer: hits[i] its nearest hit (t = inf without one), or with anyHit
 * blockedOut[i] whether it found one. */
static inline void rc_ray_store_answer(int anyHit, uint i, RcHit best, __global RcHit* hits,
                                       __global uchar* blockedOut) {
    if (anyHit) {
        blockedOut[i] = best.prim != RC_NO_HIT;
    } else {
        if (best.prim == RC_NO_HIT) best.t = INFINITY;
        hits[i] = best;
    }
}

/* The active lanes heading within 30 degrees of the lane before them, the first lane among them
 * (their squared lengths len2). */
#define RC_LANE_BEFORE 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14
static inline int16 rc_packet_smooth(const RcBvhPacket* p, float16 len2) {
    const float16 dd = p->dx * RC_SHUFFLE2(p->dx, p->dx, RC_LANE_BEFORE) +
                       p->dy * RC_SHUFFLE2(p->dy, p->dy, RC_LANE_BEFORE) +
                       p->dz * RC_SHUFFLE2(p->dz, p->dz, RC_LANE_BEFORE);
    return p->active & (dd > 0.0f) &
           (dd * dd > 0.75f * len2 * RC_SHUFFLE2(len2, len2, RC_LANE_BEFORE));
}

/* Whether the nearest-hit packet of rays [first, first + 16) below n walks the tree as one: at
 * least 12 of its lanes head within 30 degrees of its first or its last ray, or at least 8
 * within 30 degrees of the lane before them. A row of mirror rays across an edge, or refracted
 * rays through a curved surface, leave in one or two such bundles, or turn a little from lane to
 * lane (curved mirrors, several edges), and still share most of their nodes; diffuse bounces
 * scatter too widely, from lane to lane too, and their lanes would add up the nodes of 16
 * walks. Their origins' spread is not limited: a walk of 16 lanes that share few nodes still
 * waits on fewer loads than 16 single-ray walks. */
static inline int rc_bvh_packet_bundled(const RcBvhPacket* p, __global const RcRay* rays,
                                        uint first, uint n) {
    const float16 len2 = p->dx * p->dx + p->dy * p->dy + p->dz * p->dz;
    /* within 30 degrees: cos^2 > 3/4 */
    const int16 near =
        rc_packet_within(p, len2, rays[first].direction.xyz, 0.75f) |
        rc_packet_within(p, len2, rays[min(first + RC_PACKET, n) - 1].direction.xyz, 0.75f);
    return rc_count16(near) >= min(12u, n - first) ||
           rc_count16(rc_packet_smooth(p, len2)) >= min(8u, n - first);
}

/* The answers of rays [first, first + 16) (rays order[first + k] where order is given): nearest
 * hits, or with anyHit blocked flags; tests[ray] its primitive tests. A coherent packet walks
 * the tree once, a bundled packet of nearest-hit rays as its two halves, other rays one by one.
 * Shadow packets whose ends meet (a point light) walk as a beam, whatever their origins' spread,
 * when sorted by their directions from the light (ShadowOrder): their directions then lie close. */
static inline void rc_bvh_answer(int anyHit, __global const RcRay* rays, __global const uint* order,
                                 uint first, uint n, __global const RcBvh8Node* nodes,
                                 __global const float* leaves, __global const RcTriangle* triangles,
                                 __global const RcSphere* spheres,
                                 __global const RcQuadric* quadrics,
                                 __constant const RcRenderParams* params, __global RcHit* hits,
                                 __global uchar* blockedOut, __global uint* tests) {
    RcBvhPacket p;
    const float maxSpread2 = rc_bvh_max_spread2(nodes);
    const int allowed = rc_packets_allowed(params);
    const int coherent =
        allowed && rc_bvh_load_packet(rays, order, first, n, anyHit, maxSpread2, &p);
    if (allowed && anyHit) {
        const RcBvhBeam beam = rc_bvh_beam(&p);
        const int oneOctant = coherent || (order && rc_slabs_one_octant(&beam.slabs));
        if (beam.spread2 <= maxSpread2 && oneOctant) {
            int16 blocked = (int16)(0);
            const uint16 count = rc_bvh_occlude_beam(&p, &beam, nodes, leaves, &blocked);
            rc_packet_store_blocked(first, n, blocked, order, blockedOut);
            rc_packet_store_counts(first, n, count, order, tests);
            return;
        }
    }
    if (!coherent && allowed && !anyHit && rc_bvh_packet_bundled(&p, rays, first, n)) {
        float16 bt, bu, bv;
        uint16 bp;
        const uint16 count = rc_bvh_trace_halves(&p, nodes, leaves, &bt, &bp, &bu, &bv);
        rc_packet_store_hits(first, n, bt, bp, bu, bv, order, hits);
        rc_packet_store_counts(first, n, count, order, tests);
        return;
    }
    if (coherent) {
        float16 bt = p.tmax, bu = (float16)(0.0f), bv = (float16)(0.0f);
        uint16 bp = (uint16)(RC_NO_HIT);
        int16 blocked = (int16)(0);
        const uint16 count =
            rc_bvh_trace_packet(&p, anyHit, nodes, leaves, &bt, &bp, &bu, &bv, &blocked);
        rc_packet_store_answers(anyHit, first, n, bt, bp, bu, bv, blocked, order, hits, blockedOut);
        rc_packet_store_counts(first, n, count, order, tests);
        return;
    }
    for (uint k = first; k < min(first + RC_PACKET, n); ++k) {
        const uint i = order ? order[k] : k;
        const RcRay r = rays[i];
        RcHit best = rc_no_hit(r.direction.w);
        uint count = 0;
        if (rc_ray_walks(anyHit, r.direction.w, params))
            count = rc_bvh_trace(r.origin.xyz, r.direction.xyz, r.origin.w, r.direction.w, anyHit,
                                 nodes, leaves, triangles, spheres, quadrics, params->nTriangles,
                                 params->nSpheres, &best);
        rc_ray_store_answer(anyHit, i, best, hits, blockedOut);
        tests[i] = count;
    }
}

/* One work-item per 16 rays rays[16 i, 16 i + 16). */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_intersect_bvh(
    __global const RcRay* rays, uint n, __global const RcBvh8Node* nodes,
    __global const float* leaves, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global RcHit* hits, __global uint* tests) {
    const uint first = get_global_id(0) * RC_PACKET;
    if (first >= n) return;
    rc_bvh_answer(0, rays, 0, first, n, nodes, leaves, triangles, spheres, quadrics, params, hits,
                  0, tests);
}

/* Any hit before the light ends a ray's search; one work-item per 16 rays, rays order[16 i,
 * 16 i + 16) (ShadowOrder's). */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_bvh(
    __global const RcRay* rays, __global const uint* order, uint n,
    __global const RcBvh8Node* nodes, __global const float* leaves,
    __global const RcTriangle* triangles, __global const RcSphere* spheres,
    __global const RcQuadric* quadrics, __constant const RcRenderParams* params,
    __global uchar* blocked, __global uint* tests) {
    const uint first = get_global_id(0) * RC_PACKET;
    if (first >= n) return;
    rc_bvh_answer(1, rays, order, first, n, nodes, leaves, triangles, spheres, quadrics, params, 0,
                  blocked, tests);
}
