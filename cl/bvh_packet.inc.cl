/* The packet walk of cl/bvh.cl written once for any lane width: included by bvh.cl once per
 * width, with RC_W the lanes (16 or 8, the widths of OpenCL's vectors and of vec16.cl's and
 * bvh.cl's reductions), RC_W_NAME(name) the name of the packet's types and functions at that
 * width and RC_W_LANE_CULL whether the walk drops stack entries lane by lane. Every lane takes
 * the same operations at either width, so a lane's hits do not depend on the width it is walked
 * at. A file named *.inc.cl is appended at each of its includes (see AssembleProgramSource). */

#define RC_W_CAT_(a, b) a##b
#define RC_W_CAT(a, b) RC_W_CAT_(a, b)
#define floatW RC_W_CAT(float, RC_W)
#define intW RC_W_CAT(int, RC_W)
#define uintW RC_W_CAT(uint, RC_W)
#define as_uintW RC_W_CAT(as_uint, RC_W)
#define rc_minW RC_W_CAT(rc_min, RC_W)
#define rc_maxW RC_W_CAT(rc_max, RC_W)
#define rc_anyW RC_W_CAT(rc_any, RC_W)
#define rc_active_minW RC_W_CAT(rc_active_min, RC_W)
#define rc_active_maxW RC_W_CAT(rc_active_max, RC_W)
#define rc_hminW_ordered RC_W_CAT(RC_W_CAT(rc_hmin, RC_W), _ordered)
#define rc_hmaxW_ordered RC_W_CAT(RC_W_CAT(rc_hmax, RC_W), _ordered)
#define RcBvhPacketW RC_W_NAME(RcBvhPacket)
#define RcPacketPlanesW RC_W_NAME(RcPacketPlanes)
#define rc_bvh_packet_triangleW RC_W_NAME(rc_bvh_packet_triangle)
#define rc_packet_slabsW RC_W_NAME(rc_packet_slabs)
#define rc_planes_axisW RC_W_NAME(rc_planes_axis)
#define rc_packet_planesW RC_W_NAME(rc_packet_planes)
#define rc_packet_childW RC_W_NAME(rc_packet_child)
#define rc_bvh_trace_packetW RC_W_NAME(rc_bvh_trace_packet)

/* The rays of a packet, the lanes over the rays; inactive lanes hold a harmless ray. */
typedef struct RcBvhPacketW {
    floatW ox, oy, oz, dx, dy, dz, ix, iy, iz, tmin, tmax;
    intW active;
} RcBvhPacketW;

/* Triangle k of a leaf run of `count` primitives at `leaf` against the packet's rays,
 * rc_intersect_triangle's operations lane by lane: t, u and v per ray, and the rays that cross
 * the triangle between their tmin and tmax. */
static inline intW rc_bvh_packet_triangleW(const RcBvhPacketW* p, __global const float* leaf,
                                           uint count, uint k, floatW* tOut, floatW* uOut,
                                           floatW* vOut) {
    /* lane k of the run's arrays */
    __global const float* w = leaf + k;
    const float e1x = w[3 * count], e1y = w[4 * count], e1z = w[5 * count];
    const float e2x = w[6 * count], e2y = w[7 * count], e2z = w[8 * count];
    const floatW pvx = p->dy * e2z - e2y * p->dz;
    const floatW pvy = p->dz * e2x - e2z * p->dx;
    const floatW pvz = p->dx * e2y - e2x * p->dy;
    const floatW det = e1x * pvx + e1y * pvy + e1z * pvz;
    const floatW invDet = 1.0f / det;
    const floatW tvx = p->ox - w[0];
    const floatW tvy = p->oy - w[count];
    const floatW tvz = p->oz - w[2 * count];
    const floatW u = (tvx * pvx + tvy * pvy + tvz * pvz) * invDet;
    const floatW qvx = tvy * e1z - e1y * tvz;
    const floatW qvy = tvz * e1x - e1z * tvx;
    const floatW qvz = tvx * e1y - e1x * tvy;
    const floatW v = (p->dx * qvx + p->dy * qvy + p->dz * qvz) * invDet;
    const floatW t = (e2x * qvx + e2y * qvy + e2z * qvz) * invDet;
    *tOut = t;
    *uOut = u;
    *vOut = v;
    return (det != 0.0f) & (u >= 0.0f) & (u <= 1.0f) & (v >= 0.0f) & (u + v <= 1.0f) &
           (t > p->tmin) & (t < p->tmax);
}

/* The packet's active lanes as intervals: their origins and inverse directions. */
static inline RcBvhSlabs rc_packet_slabsW(const RcBvhPacketW* p) {
    RcBvhSlabs s;
    rc_slabs_axis(rc_active_minW(p->ox, p->active), rc_active_maxW(p->ox, p->active),
                  rc_active_minW(p->ix, p->active), rc_active_maxW(p->ix, p->active), 0, &s);
    rc_slabs_axis(rc_active_minW(p->oy, p->active), rc_active_maxW(p->oy, p->active),
                  rc_active_minW(p->iy, p->active), rc_active_maxW(p->iy, p->active), 1, &s);
    rc_slabs_axis(rc_active_minW(p->oz, p->active), rc_active_maxW(p->oz, p->active),
                  rc_active_minW(p->iz, p->active), rc_active_maxW(p->iz, p->active), 2, &s);
    return s;
}

/* The per-lane slab test of a packet whose active lanes share an octant (along each axis their
 * inverse directions have one sign), one multiply-add a plane: a box's entry
 * distance along axis a is fma(near side, inv, nearOff) with nearOff = -o * inv - m, its exit
 * fma(far side, inv, farOff) with farOff = -o * inv + m. The sign tells the near side, so no
 * min or max of the two planes is needed. The margin m = |o * inv| 2^-22 outweighs the rounding
 * of o * inv and of the offsets (2 ulp of |o * inv| together), so each distance is within one
 * rounding of the exact (side - o) * inv, entries below and exits above it: no farther from it
 * than the single-ray walk's own distances, which its far distance's widening covers. Packets
 * in several octants, or with an offset that overflows (a huge inverse), are not `usable`. */
typedef struct RcPacketPlanesW {
    floatW nearOff[3], farOff[3];
    int nearPlanes[3], farPlanes[3]; /* the near and far sides in rc_bvh_planes */
    int usable;
} RcPacketPlanesW;

/* Axis a of the planes; returns the lanes whose offsets are finite. */
static inline intW rc_planes_axisW(floatW o, floatW inv, int positive, int a, RcPacketPlanesW* q) {
    const floatW oi = o * inv;
    const floatW m = fabs(oi) * 0x1p-22f;
    q->nearOff[a] = -oi - m;
    q->farOff[a] = -oi + m;
    q->nearPlanes[a] = rc_bvh_near_planes(positive, a);
    q->farPlanes[a] = rc_bvh_far_planes(q->nearPlanes[a]);
    return isfinite(q->nearOff[a]) & isfinite(q->farOff[a]);
}

static inline RcPacketPlanesW rc_packet_planesW(const RcBvhPacketW* p, int px, int py, int pz,
                                                int oneOctant) {
    RcPacketPlanesW q;
    const intW finite = rc_planes_axisW(p->ox, p->ix, px, 0, &q) &
                        rc_planes_axisW(p->oy, p->iy, py, 1, &q) &
                        rc_planes_axisW(p->oz, p->iz, pz, 2, &q);
    q.usable = oneOctant && !rc_anyW(p->active & ~finite);
    return q;
}

/* The lanes' entry (*tn, at least tmin) and widened exit (*tf) distances of child c of nd:
 * with one multiply-add a plane where the planes are usable, else with the single-ray walk's
 * operations lane by lane. */
static inline void rc_packet_childW(const RcBvhPacketW* p, const RcPacketPlanesW* q,
                                    __global const RcBvh8Node* nd, uint c, floatW* tn, floatW* tf) {
    if (q->usable) {
        __global const float* planes = rc_bvh_planes(nd) + c;
        const floatW nx = fma((floatW)(planes[q->nearPlanes[0]]), p->ix, q->nearOff[0]);
        const floatW ny = fma((floatW)(planes[q->nearPlanes[1]]), p->iy, q->nearOff[1]);
        const floatW nz = fma((floatW)(planes[q->nearPlanes[2]]), p->iz, q->nearOff[2]);
        const floatW fx = fma((floatW)(planes[q->farPlanes[0]]), p->ix, q->farOff[0]);
        const floatW fy = fma((floatW)(planes[q->farPlanes[1]]), p->iy, q->farOff[1]);
        const floatW fz = fma((floatW)(planes[q->farPlanes[2]]), p->iz, q->farOff[2]);
        *tn = rc_maxW(rc_maxW(nx, ny), rc_maxW(nz, p->tmin));
        *tf = rc_minW(rc_minW(fx, fy), fz) * 1.0000004f;
        return;
    }
    const floatW ax = (nd->loX[c] - p->ox) * p->ix, bx = (nd->hiX[c] - p->ox) * p->ix;
    const floatW ay = (nd->loY[c] - p->oy) * p->iy, by = (nd->hiY[c] - p->oy) * p->iy;
    const floatW az = (nd->loZ[c] - p->oz) * p->iz, bz = (nd->hiZ[c] - p->oz) * p->iz;
    *tn = rc_maxW(rc_maxW(rc_minW(ax, bx), rc_minW(ay, by)), rc_maxW(rc_minW(az, bz), p->tmin));
    *tf = rc_minW(rc_minW(rc_maxW(ax, bx), rc_maxW(ay, by)), rc_maxW(az, bz)) * 1.0000004f;
}

/* Walks the tree once for the packet: nearest hits in (bt, bp, bu, bv), or with anyHit the lanes
 * that found a hit in *blocked (a lane stops at its first). Returns primitive tests per lane. */
static inline uintW rc_bvh_trace_packetW(const RcBvhPacketW* p, int anyHit,
                                         __global const RcBvh8Node* nodes,
                                         __global const float* leaves, floatW* btOut, uintW* bpOut,
                                         floatW* buOut, floatW* bvOut, intW* blocked) {
    uint stackRef[RC_BVH_STACK];
    float stackT[RC_BVH_STACK];
#if RC_W_LANE_CULL
    /* Per entry the entry distances of the lanes that entered it (NaN in the others, which no
     * compare passes): a lane whose entry lies beyond its nearest hit found since cannot hit
     * nearer in it (the child test's cull by reach), so an entry none of its lanes still reaches
     * is dropped, where the packet's `far` keeps it for lanes that did not enter it. */
    floatW stackLanesT[RC_BVH_STACK];
#endif
    int sp = 0;
    uint ref = 0;
    uintW tests = (uintW)(0);
    intW active = p->active;
    /* The answers stay in registers during the walk. */
    floatW bt = *btOut, bu = *buOut, bv = *bvOut;
    uintW bp = *bpOut;
    const RcBvhSlabs span = rc_packet_slabsW(p);
    const RcPacketPlanesW planes = rc_packet_planesW(p, span.positive[0], span.positive[1],
                                                     span.positive[2], rc_slabs_one_octant(&span));
    const float spanTmin = rc_active_minW(p->tmin, p->active);
    const int8 laneBit = (int8)(1, 2, 4, 8, 16, 32, 64, 128);
    /* The farthest distance an active lane can still improve on. */
    float far = rc_hmaxW_ordered(select((floatW)(-INFINITY), bt, active));
    for (;;) {
        if (ref & RC_BVH8_LEAF) {
            const uint count = ((ref & ~RC_BVH8_LEAF) >> RC_BVH8_COUNT_SHIFT) + 1;
            __global const float* leaf = leaves + (ref & RC_BVH8_FIRST_MASK) * RC_BVH_LEAF_ALIGN;
            /* Without anyHit the lanes stay active through the leaf. */
            if (!anyHit) tests += as_uintW(active) & (uintW)(count);
            for (uint k = 0; k < count; ++k) {
                if (anyHit) tests += as_uintW(active) & (uintW)(1);
                floatW t, u, v;
                const intW crosses = rc_bvh_packet_triangleW(p, leaf, count, k, &t, &u, &v);
                const uintW primW = (uintW)(rc_leaf_prim(leaf, count, k));
                const intW hit = active & crosses & ((t < bt) | ((t == bt) & (primW < bp)));
                bt = select(bt, t, hit);
                bp = select(bp, primW, as_uintW(hit));
                bu = select(bu, u, hit);
                bv = select(bv, v, hit);
                if (anyHit) {
                    *blocked |= hit;
                    active &= ~hit;
                    if (!rc_anyW(active)) {
                        *btOut = bt, *bpOut = bp, *buOut = bu, *bvOut = bv;
                        return tests;
                    }
                }
            }
            far = rc_hmaxW_ordered(select((floatW)(-INFINITY), bt, active));
        } else {
            __global const RcBvh8Node* nd = nodes + ref;
            const floatW reach = rc_minW(p->tmax, bt);
            /* Only the children some lane may enter take the per-lane test. */
            float8 sn = (float8)(spanTmin), sf = (float8)(INFINITY);
            rc_slabs_test(&span, 0, nd, &sn, &sf);
            rc_slabs_test(&span, 1, nd, &sn, &sf);
            rc_slabs_test(&span, 2, nd, &sn, &sf);
            const int8 may = (sn <= rc_min8(sf * 1.0000004f, (float8)(far))) &
                             (laneBit < (int8)(1 << nd->nChildren)) & laneBit;
            const int4 m4 = may.lo | may.hi;
            const int2 m2 = m4.lo | m4.hi;
            /* The children taken (their slots in nd), nearest first. */
            uint slot[8];
            float t[8];
#if RC_W_LANE_CULL
            floatW lanesT[8]; /* per slot the entries of the lanes that enter it */
#endif
            int k = 0;
            for (int mask = m2.x | m2.y; mask != 0; mask &= mask - 1) {
                const int c = popcount((mask & -mask) - 1);
                floatW tn, tf;
                rc_packet_childW(p, &planes, nd, c, &tn, &tf);
                const intW enters = active & (tn <= rc_minW(tf, reach));
                if (!rc_anyW(enters)) continue;
                /* The nearest entry over the lanes that enter orders and culls the child. */
                const float near = rc_hminW_ordered(select((floatW)(INFINITY), tn, enters));
                int j = k++;
                for (; !anyHit && j > 0 && t[j - 1] > near; --j) {
                    t[j] = t[j - 1];
                    slot[j] = slot[j - 1];
                }
                t[j] = near;
                slot[j] = c;
#if RC_W_LANE_CULL
                lanesT[c] = select((floatW)(NAN), tn, enters);
#endif
            }
            if (k > 0) {
                for (int j = k - 1; j > 0; --j) {
                    stackRef[sp] = nd->child[slot[j]];
#if RC_W_LANE_CULL
                    stackLanesT[sp] = lanesT[slot[j]];
#endif
                    stackT[sp++] = t[j];
                }
                ref = nd->child[slot[0]];
                continue;
            }
        }
        /* An entry no lane can still improve on is dropped. */
        for (;;) {
            if (sp == 0) {
                *btOut = bt, *bpOut = bp, *buOut = bu, *bvOut = bv;
                return tests;
            }
            --sp;
#if RC_W_LANE_CULL
            if (stackT[sp] <= far && rc_anyW(stackLanesT[sp] <= bt)) break;
#else
            if (stackT[sp] <= far) break;
#endif
        }
        ref = stackRef[sp];
    }
}

#undef RC_W_CAT_
#undef RC_W_CAT
#undef floatW
#undef intW
#undef uintW
#undef as_uintW
#undef rc_minW
#undef rc_maxW
#undef rc_anyW
#undef rc_active_minW
#undef rc_active_maxW
#undef rc_hminW_ordered
#undef rc_hmaxW_ordered
#undef RcBvhPacketW
#undef RcPacketPlanesW
#undef rc_bvh_packet_triangleW
#undef rc_packet_slabsW
#undef rc_planes_axisW
#undef rc_packet_planesW
#undef rc_packet_childW
#undef rc_bvh_trace_packetW
