/* Szecsi's hierarchical ray engine (include/rayclass/accel/cones.h) as ray queries: the rays of
 * a batch sorted into coherent tiles, each tile and each group of tiles enclosed in a cone. The
 * cull kernels (the paper's vertex-unit step) test primitives' bounding spheres against the
 * cones, a group's cone against every primitive (sixteen spheres a step, float16 over structure
 * of arrays), a tile's cone against its group's survivors; each runs twice, first counting the
 * survivors, then, at the offsets the host summed, writing them. Then every ray tests only its
 * tile's survivors (the fragment-unit step), sixteen rays of a tile together, with the routines
 * of intersect.cl or their float16 twin for triangles (lower id wins ties), so the hits equal
 * brute force's. A list of RC_CONES_ALL entries stands for every
 * primitive (an unbounded cone, or a list that did not fit). The cones themselves are built here
 * too (rc_cones_build), sixteen tiles a work-item, from the rays the host sorted into tiles. */
#include "rc_types.h"
#include "intersect.cl"
#include "bvh.cl"
#include "accel_common.cl"
#include "vec16.cl"

#pragma OPENCL FP_CONTRACT OFF

#define RC_CONES_ALL 0xFFFFFFFFu
#define RC_CONE_TILE_RAYS 64
#define RC_CONE_GROUP_TILES 16

/* Whether spheres (centre c, radius r) meet the cone (Eberly's cone-sphere test: the centre
 * inside the cone grown by r, then the region behind the apex), with angles compared through
 * the perpendicular distance, which keeps its precision in narrow cones. */
static inline int16 rc_cone_spheres16(RcCone cone, float16 cx, float16 cy, float16 cz, float16 r) {
    if (cone.apex.w < 0.0f) return (int16)(-1);
    const float tan2 = cone.apex.w, invSin = cone.axis.w;
    const float ax = cone.axis.x, ay = cone.axis.y, az = cone.axis.z;
    /* From the apex of the cone grown by r, r / sin(phi) behind the apex. */
    const float16 k = r * invSin;
    const float16 dx = cx - cone.apex.x + k * ax, dy = cy - cone.apex.y + k * ay,
                  dz = cz - cone.apex.z + k * az;
    const float16 e = dx * ax + dy * ay + dz * az;
    const float16 px = dy * az - dz * ay, py = dz * ax - dx * az, pz = dx * ay - dy * ax;
    const int16 inGrown = (e > 0.0f) & (px * px + py * py + pz * pz <= e * e * tan2);
    /* Behind the apex only the ball around it may meet the cone. */
    const float16 bx = cx - cone.apex.x, by = cy - cone.apex.y, bz = cz - cone.apex.z;
    const float16 f = -(bx * ax + by * ay + bz * az);
    const float16 qx = by * az - bz * ay, qy = bz * ax - bx * az, qz = bx * ay - by * ax;
    const int16 behind = (f > 0.0f) & ((qx * qx + qy * qy + qz * qz) * tan2 <= f * f);
    return inGrown & (~behind | (bx * bx + by * by + bz * bz <= r * r));
}

static inline int rc_cone_sphere(RcCone cone, float cx, float cy, float cz, float r) {
    return rc_cone_spheres16(cone, (float16)(cx), (float16)(cy), (float16)(cz), (float16)(r)).s0;
}

/* --- the cones, built on the device ----------------------------------------------------------
 * A work-item builds the cones of one group's 16 tiles, a tile a lane, by accel::EnclosingCone's
 * construction (rayclass/accel/cones.h) in float: the paper's steps (a) and (b) ray by ray, then
 * every direction and every origin checked against the final cone and the half-angle and apex
 * widened by the same margins. The angles are measured as atan2 of the cross and dot products:
 * an acos of a cosine near 1 would lose them in float. Then the group's cone from its tiles',
 * as accel::EnclosingConeOfCones. */
#define RC_CONE_MIN_HALF_ANGLE 1e-3f
#define RC_CONE_MAX_HALF_ANGLE (89.0f * M_PI_F / 180.0f)
#define RC_CONE_ANGLE_MARGIN 1e-4f

/* The angle between a and b (any lengths), accurate down to 0. */
static inline float16 rc_v16_angle(RcVec16 a, RcVec16 b) {
    return atan2(rc_v16_length(rc_v16_cross(a, b)), rc_v16_dot(a, b));
}

/* Ray k of each lane's tile (tile 16 g + lane: sorted positions [64 tile, 64 tile + 64) below
 * n): origin, unit direction, and whether it counts (it exists and has a direction). */
static inline int16 rc_cones_tile_ray16(__global const RcRay* sorted, uint n, uint g, uint k,
                                        RcVec16* o, RcVec16* r) {
    float ox[RC_PACKET], oy[RC_PACKET], oz[RC_PACKET], dx[RC_PACKET], dy[RC_PACKET],
        dz[RC_PACKET];
    int ok[RC_PACKET];
    for (uint l = 0; l < RC_PACKET; ++l) {
        const uint j = (g * RC_CONE_GROUP_TILES + l) * RC_CONE_TILE_RAYS + k;
        float4 ro = (float4)(0.0f), rd = (float4)(0.0f);
        if (j < n) ro = sorted[j].origin, rd = sorted[j].direction;
        ox[l] = ro.x, oy[l] = ro.y, oz[l] = ro.z;
        /* Scaled first, so that a tiny direction's squared length does not underflow. */
        const float m = fmax(fmax(fabs(rd.x), fabs(rd.y)), fabs(rd.z));
        ok[l] = m > 0.0f;
        const float3 d = ok[l] ? rd.xyz / m : (float3)(0.0f, 0.0f, 1.0f);
        dx[l] = d.x, dy[l] = d.y, dz[l] = d.z;
    }
    *o = rc_v16(vload16(0, ox), vload16(0, oy), vload16(0, oz));
    const RcVec16 d = rc_v16(vload16(0, dx), vload16(0, dy), vload16(0, dz));
    *r = rc_v16_scale(d, 1.0f / rc_v16_length(d));
    return vload16(0, ok) != 0;
}

/* Step (a), in the lanes `m`: the smallest cone with the same apex holding the cone (axis *x,
 * half-angle's cosine and sine *c, *s) and the unit direction r. Returns the lanes where that
 * cone would open to 180 degrees or beyond the largest half-angle. */
static inline int16 rc_cones_widen_to_direction(int16 m, RcVec16* x, float16* c, float16* s,
                                                RcVec16 r) {
    const float16 cr = rc_v16_dot(*x, r);
    const int16 need = m & (cr < *c);
    if (!any(need)) return (int16)(0);
    const RcVec16 qRaw = rc_v16_sub(rc_v16_scale(*x, cr), r);
    const float16 lq = rc_v16_length(qRaw);
    /* r along the axis (up to rounding), or opposite it */
    const int16 tiny = lq < 1e-6f;
    int16 bad = need & tiny & (cr <= 0.0f);
    const int16 widen = need & ~tiny;
    const RcVec16 q = rc_v16_scale(qRaw, 1.0f / select((float16)(1.0f), lq, widen));
    const RcVec16 er = rc_v16_add(rc_v16_add(rc_v16_scale(*x, *c), rc_v16_scale(q, *s)), r);
    const float16 ler = rc_v16_length(er);
    /* r opposite the far generator */
    bad |= widen & (ler < 1e-6f);
    const int16 take = widen & (ler >= 1e-6f);
    const RcVec16 xn = rc_v16_scale(er, 1.0f / select((float16)(1.0f), ler, take));
    *x = rc_v16_select(*x, xn, take);
    *c = select(*c, rc_v16_dot(xn, r), take);
    *s = select(*s, rc_v16_length(rc_v16_cross(xn, r)), take);
    return bad | (take & (*c <= cos(RC_CONE_MAX_HALF_ANGLE)));
}

/* Step (b), in the lanes `m`: where p lies outside the cone (apex *a, axis x, half-angle's
 * cosine and sine c, s), the apex slides back along the far generator until the near one passes
 * through p, or where no slide reaches p, backs off along the axis (accel::EnclosingCone). */
static inline void rc_cones_widen_to_origin(int16 m, RcVec16* a, RcVec16 x, float16 c, float16 s,
                                            RcVec16 p) {
    const RcVec16 cv = rc_v16_sub(p, *a);
    const float16 along = rc_v16_dot(x, cv);
    const RcVec16 qRaw = rc_v16_sub(rc_v16_scale(x, along), cv);
    const float16 across = rc_v16_length(qRaw);
    const int16 out = m & ~((along >= 0.0f) & (across * c <= along * s));
    if (!any(out)) return;
    const int16 off = across > 1e-6f * rc_v16_length(cv);
    const RcVec16 q = rc_v16_scale(qRaw, 1.0f / select((float16)(1.0f), across, off));
    const RcVec16 e = rc_v16_add(rc_v16_scale(x, c), rc_v16_scale(q, s));
    const RcVec16 nn = rc_v16_sub(rc_v16_scale(x, c), rc_v16_scale(q, s));
    const RcVec16 g = rc_v16_sub(cv, rc_v16_scale(nn, rc_v16_dot(nn, cv)));
    const float16 eg = rc_v16_dot(e, g);
    const int16 slide = out & off & (eg < 0.0f);
    const float16 bySlide = rc_v16_dot(g, g) / select((float16)(1.0f), -eg, slide);
    const float16 byAxis = across * c / s - along;
    *a = rc_v16_select(*a, rc_v16_sub(*a, rc_v16_scale(e, bySlide)), slide);
    *a = rc_v16_select(*a, rc_v16_sub(*a, rc_v16_scale(x, byAxis)), out & ~slide);
}

/* A cone that culls nothing (accel::EnclosingCone's unbounded one). */
static inline RcCone rc_cones_unbounded(void) {
    RcCone c;
    c.apex = (float4)(0.0f, 0.0f, 0.0f, -1.0f);
    c.axis = (float4)(0.0f, 0.0f, 1.0f, 1.0f);
    return c;
}

/* The cone of apex a, axis x and half-angle phi as the cull kernels read it. */
static inline RcCone rc_cones_make(float3 a, float3 x, float phi) {
    RcCone c;
    const float t = tan(phi);
    c.apex = (float4)(a, t * t);
    c.axis = (float4)(x, 1.0f / sin(phi));
    return c;
}

/* The group's cone from its tiles' (axes x, half-angles phi, apexes a, `count` of them): the
 * mean axis, the half-angle holding every tile's directions, and the apex backed off along the
 * axis until every tile's apex lies inside, half the margin from the surface. */
static inline RcCone rc_cones_group(const float* ax, const float* ay, const float* az,
                                    const float* px, const float* py, const float* pz,
                                    const float* phis, const int* bad, uint count, float margin) {
    float3 sum = (float3)(0.0f), centroid = (float3)(0.0f);
    int unbounded = count == 0;
    for (uint t = 0; t < count; ++t) {
        unbounded |= bad[t];
        sum += (float3)(ax[t], ay[t], az[t]);
        centroid += (float3)(px[t], py[t], pz[t]);
    }
    const float ls = length(sum);
    if (unbounded || ls < 1e-6f) return rc_cones_unbounded();
    const float3 x = sum / ls;
    centroid /= (float)count;
    float phi = 0.0f;
    for (uint t = 0; t < count; ++t) {
        const float3 axis = (float3)(ax[t], ay[t], az[t]);
        phi = fmax(phi, atan2(length(cross(x, axis)), dot(x, axis)) + phis[t]);
    }
    phi = fmax(phi + RC_CONE_ANGLE_MARGIN, RC_CONE_MIN_HALF_ANGLE);
    if (phi >= RC_CONE_MAX_HALF_ANGLE) return rc_cones_unbounded();
    const float tanInner = tan(phi - 0.5f * RC_CONE_ANGLE_MARGIN);
    float back = 0.0f;
    for (uint t = 0; t < count; ++t) {
        const float3 d = (float3)(px[t], py[t], pz[t]) - centroid;
        const float along = dot(d, x);
        back = fmax(back, length(d - along * x) / tanInner - along);
    }
    return rc_cones_make(centroid - (back + margin) * x, x, phi);
}

/* The cones of group g's tiles, tiles[16 g ...] (those below nTiles), and of the group,
 * groups[g]; `margin` the absolute distance every apex backs off further. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_cones_build(
    __global const RcRay* sorted, uint n, uint nTiles, float margin, __global RcCone* tiles,
    __global RcCone* groups) {
    const uint g = get_global_id(0);
    if (g * RC_CONE_GROUP_TILES >= nTiles) return;
    RcVec16 x = rc_v16((float16)(0.0f), (float16)(0.0f), (float16)(1.0f)), o, r;
    RcVec16 a = rc_v16((float16)(0.0f), (float16)(0.0f), (float16)(0.0f));
    float16 c = (float16)(cos(RC_CONE_MIN_HALF_ANGLE)), s = (float16)(sin(RC_CONE_MIN_HALF_ANGLE));
    int16 seen = (int16)(0), bad = (int16)(0);
    for (uint k = 0; k < RC_CONE_TILE_RAYS; ++k) {
        const int16 ok = rc_cones_tile_ray16(sorted, n, g, k, &o, &r);
        const int16 first = ok & ~seen;
        x = rc_v16_select(x, r, first);
        a = rc_v16_select(a, o, first);
        seen |= first;
        const int16 m = ok & ~first & ~bad;
        if (!any(m)) continue;
        bad |= rc_cones_widen_to_direction(m, &x, &c, &s, r);
        rc_cones_widen_to_origin(m & ~bad, &a, x, c, s, o);
    }
    bad |= ~seen;
    /* Every direction checked against the final axis, then the margin. */
    float16 widest = (float16)(0.0f);
    for (uint k = 0; k < RC_CONE_TILE_RAYS; ++k) {
        const int16 ok = rc_cones_tile_ray16(sorted, n, g, k, &o, &r);
        widest = select(widest, fmax(widest, rc_v16_angle(x, r)), ok);
    }
    const float16 phi = fmax(widest + RC_CONE_ANGLE_MARGIN, (float16)(RC_CONE_MIN_HALF_ANGLE));
    bad |= phi >= RC_CONE_MAX_HALF_ANGLE;
    /* Every origin checked too: the apex backs off along the axis until each lies inside, half
     * the margin from the surface. */
    const float16 tanInner = tan(phi - 0.5f * RC_CONE_ANGLE_MARGIN);
    float16 back = (float16)(0.0f);
    for (uint k = 0; k < RC_CONE_TILE_RAYS; ++k) {
        const int16 ok = rc_cones_tile_ray16(sorted, n, g, k, &o, &r);
        const RcVec16 cv = rc_v16_sub(o, a);
        const float16 along = rc_v16_dot(cv, x);
        const float16 across = rc_v16_length(rc_v16_sub(cv, rc_v16_scale(x, along)));
        back = select(back, fmax(back, across / tanInner - along), ok);
    }
    a = rc_v16_sub(a, rc_v16_scale(x, back + margin));
    float ax[RC_PACKET], ay[RC_PACKET], az[RC_PACKET], px[RC_PACKET], py[RC_PACKET],
        pz[RC_PACKET], phis[RC_PACKET];
    int bads[RC_PACKET];
    vstore16(x.x, 0, ax), vstore16(x.y, 0, ay), vstore16(x.z, 0, az);
    vstore16(a.x, 0, px), vstore16(a.y, 0, py), vstore16(a.z, 0, pz);
    vstore16(phi, 0, phis), vstore16(bad, 0, bads);
    const uint count = min((uint)RC_CONE_GROUP_TILES, nTiles - g * RC_CONE_GROUP_TILES);
    for (uint t = 0; t < count; ++t) {
        tiles[g * RC_CONE_GROUP_TILES + t] =
            bads[t] ? rc_cones_unbounded()
                    : rc_cones_make((float3)(px[t], py[t], pz[t]), (float3)(ax[t], ay[t], az[t]),
                                    phis[t]);
    }
    groups[g] = rc_cones_group(ax, ay, az, px, py, pz, phis, bads, count, margin);
}

/* Group cones against every primitive. write = 0: counts[g] = survivors; else the survivors'
 * ids go to list[offsets[g] ...] (groups whose offset is RC_CONES_ALL are skipped). */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_cones_cull_groups(
    __global const RcCone* cones, uint nGroups, __global const float* sx,
    __global const float* sy, __global const float* sz, __global const float* sr, uint nPrims,
    uint write, __global const uint* offsets, __global uint* counts, __global uint* list) {
    const uint g = get_global_id(0);
    if (g >= nGroups) return;
    const RcCone cone = cones[g];
    if (write && offsets[g] == RC_CONES_ALL) return;
    uint count = 0;
    const uint base = write ? offsets[g] : 0;
    const int16 lane = (int16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    for (uint b = 0; b < nPrims; b += 16) {
        const int16 hit = rc_cone_spheres16(cone, vload16(0, sx + b), vload16(0, sy + b),
                                            vload16(0, sz + b), vload16(0, sr + b)) &
                          (lane < (int16)(nPrims - b));
        int mask[16];
        vstore16(hit, 0, mask);
        for (int k = 0; k < 16; ++k) {
            if (mask[k]) {
                if (write) list[base + count] = b + k;
                ++count;
            }
        }
    }
    if (!write) counts[g] = count;
}

/* Tile cones against their group's survivors (every primitive where the group has
 * RC_CONES_ALL). Counts and writes as above. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_cones_cull_tiles(
    __global const RcCone* cones, uint nTiles, __global const uint* groupOffsets,
    __global const uint* groupCounts, __global const uint* groupList, __global const float* sx,
    __global const float* sy, __global const float* sz, __global const float* sr, uint nPrims,
    uint write, __global const uint* offsets, __global uint* counts, __global uint* list) {
    const uint t = get_global_id(0);
    if (t >= nTiles) return;
    const RcCone cone = cones[t];
    if (write && offsets[t] == RC_CONES_ALL) return;
    const uint g = t / RC_CONE_GROUP_TILES;
    const int all = groupOffsets[g] == RC_CONES_ALL;
    const uint n = all ? nPrims : groupCounts[g];
    __global const uint* from = groupList + (all ? 0 : groupOffsets[g]);
    uint count = 0;
    const uint base = write ? offsets[t] : 0;
    for (uint k = 0; k < n; ++k) {
        const uint id = all ? k : from[k];
        if (rc_cone_sphere(cone, sx[id], sy[id], sz[id], sr[id])) {
            if (write) list[base + count] = id;
            ++count;
        }
    }
    if (!write) counts[t] = count;
}

/* The candidates of sorted position j's tile: *n of them from *ids, or all. */
static inline uint rc_cones_tile_candidates(uint j, __global const uint* tileOffsets,
                                            __global const uint* tileCounts,
                                            __global const uint* tileList, uint nPrims,
                                            __global const uint** ids) {
    const uint t = j / RC_CONE_TILE_RAYS;
    if (tileOffsets[t] == RC_CONES_ALL) {
        *ids = 0;
        return nPrims;
    }
    *ids = tileList + tileOffsets[t];
    return tileCounts[t];
}

/* Primitive `id` against the lanes `live` one lane at a time, through rc_intersect_primitive.
 * Returns the lanes it hit. */
static inline int16 rc_cones_primitive_lanes(const RcBvhPacket* p, int16 live, uint id,
                                             __global const RcTriangle* triangles,
                                             __global const RcSphere* spheres,
                                             __global const RcQuadric* quadrics, uint nT, uint nS,
                                             float16* bt, uint16* bp, float16* bu, float16* bv) {
    float ox[RC_PACKET], oy[RC_PACKET], oz[RC_PACKET], dx[RC_PACKET], dy[RC_PACKET],
        dz[RC_PACKET], tn[RC_PACKET], tf[RC_PACKET], ts[RC_PACKET], us[RC_PACKET], vs[RC_PACKET];
    uint ps[RC_PACKET];
    int lanes[RC_PACKET], hits[RC_PACKET];
    vstore16(p->ox, 0, ox), vstore16(p->oy, 0, oy), vstore16(p->oz, 0, oz);
    vstore16(p->dx, 0, dx), vstore16(p->dy, 0, dy), vstore16(p->dz, 0, dz);
    vstore16(p->tmin, 0, tn), vstore16(p->tmax, 0, tf);
    vstore16(*bt, 0, ts), vstore16(*bu, 0, us), vstore16(*bv, 0, vs), vstore16(*bp, 0, ps);
    vstore16(live, 0, lanes);
    for (int k = 0; k < RC_PACKET; ++k) {
        hits[k] = 0;
        if (!lanes[k]) continue;
        RcHit best;
        best.t = ts[k], best.prim = ps[k], best.u = us[k], best.v = vs[k];
        hits[k] = rc_intersect_primitive(id, (float3)(ox[k], oy[k], oz[k]),
                                         (float3)(dx[k], dy[k], dz[k]), tn[k], tf[k], triangles,
                                         spheres, quadrics, nT, nS, &best)
                      ? -1
                      : 0;
        ts[k] = best.t, ps[k] = best.prim, us[k] = best.u, vs[k] = best.v;
    }
    *bt = vload16(0, ts), *bu = vload16(0, us), *bv = vload16(0, vs), *bp = vload16(0, ps);
    return vload16(0, hits);
}

/* The packet against its tile's `count` candidates (ids, or every primitive where ids is 0):
 * triangles sixteen lanes at once with rc_intersect_triangle's operations (accel_common.cl),
 * other primitives lane by lane; with anyHit a lane stops at its first hit. Returns the
 * primitive tests per lane. */
static inline uint16 rc_cones_packet(const RcBvhPacket* p, int anyHit, uint count,
                                     __global const uint* ids, __global const RcTriangle* triangles,
                                     __global const RcSphere* spheres,
                                     __global const RcQuadric* quadrics, uint nT, uint nS,
                                     float16* bt, uint16* bp, float16* bu, float16* bv,
                                     int16* blocked) {
    int16 live = p->active;
    uint16 tests = (uint16)(0);
    for (uint k = 0; k < count && any(live); ++k) {
        const uint id = ids ? ids[k] : k;
        tests += as_uint16(live) & (uint16)(1);
        int16 hit;
#ifndef RC_WATERTIGHT
        if (id < nT) {
            __global const RcTriangle* tri = triangles + id;
            const float3 v0 = tri->v0.xyz;
            hit = rc_accel_triangle16(p, live, v0, tri->v1.xyz - v0, tri->v2.xyz - v0, id, bt, bp,
                                      bu, bv);
        } else
#endif
        {
            hit = rc_cones_primitive_lanes(p, live, id, triangles, spheres, quadrics, nT, nS, bt,
                                           bp, bu, bv);
        }
        if (anyHit) {
            *blocked |= hit;
            live &= ~hit;
        }
    }
    return tests;
}

/* The answers of the rays at sorted positions [first, first + 16) (all of one tile), whose
 * places in the batch are order[j]: nearest hits, or with anyHit blocked flags; counters[ray]
 * the primitive tests. */
static inline void rc_cones_answer(int anyHit, __global const RcRay* sorted, uint first, uint n,
                                   __global const uint* order, __global const uint* tileOffsets,
                                   __global const uint* tileCounts, __global const uint* tileList,
                                   __global const RcTriangle* triangles,
                                   __global const RcSphere* spheres,
                                   __global const RcQuadric* quadrics,
                                   __constant const RcRenderParams* params, __global RcHit* hits,
                                   __global uchar* blockedOut, __global uint* counters) {
    const uint nT = params->nTriangles, nS = params->nSpheres;
    const uint nPrims = nT + nS + params->nQuadrics;
    __global const uint* ids;
    const uint count =
        rc_cones_tile_candidates(first, tileOffsets, tileCounts, tileList, nPrims, &ids);
    /* A tile's rays always test its candidates together: the BVH's coherence verdict is moot. */
    RcBvhPacket p;
    rc_bvh_load_packet(sorted, 0, first, n, anyHit, INFINITY, &p);
    float16 bt = p.tmax, bu = (float16)(0.0f), bv = (float16)(0.0f);
    uint16 bp = (uint16)(RC_NO_HIT);
    int16 blocked = (int16)(0);
    const uint16 tests = rc_cones_packet(&p, anyHit, count, ids, triangles, spheres, quadrics, nT,
                                         nS, &bt, &bp, &bu, &bv, &blocked);
    rc_packet_store_answers(anyHit, first, n, bt, bp, bu, bv, blocked, order, hits, blockedOut);
    rc_packet_store_counts(first, n, tests, order, counters);
}

/* One work-item per 16 sorted positions [16 w, 16 w + 16). A tile's rays (RC_CONE_TILE_RAYS, a
 * multiple of 16) test its candidates together. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_intersect_cones(
    __global const RcRay* sorted, uint n, __global const uint* order,
    __global const uint* tileOffsets, __global const uint* tileCounts,
    __global const uint* tileList, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global RcHit* hits, __global uint* counters) {
    const uint first = get_global_id(0) * RC_PACKET;
    if (first >= n) return;
    rc_cones_answer(0, sorted, first, n, order, tileOffsets, tileCounts, tileList, triangles,
                    spheres, quadrics, params, hits, 0, counters);
}

/* Any hit before the light ends a ray's search; one work-item per 16 sorted positions. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_cones(
    __global const RcRay* sorted, uint n, __global const uint* order,
    __global const uint* tileOffsets, __global const uint* tileCounts,
    __global const uint* tileList, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global uchar* blocked, __global uint* counters) {
    const uint first = get_global_id(0) * RC_PACKET;
    if (first >= n) return;
    rc_cones_answer(1, sorted, first, n, order, tileOffsets, tileCounts, tileList, triangles,
                    spheres, quadrics, params, 0, blocked, counters);
}
