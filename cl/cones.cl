/* Szecsi's hierarchical ray engine (include/rayclass/accel/cones.h) as ray queries: the rays of
 * a batch sorted into coherent tiles, each tile and each group of tiles enclosed in a cone. The
 * cull kernels (the paper's vertex-unit step) test primitives' bounding spheres against the
 * cones, a group's cone against every primitive (sixteen spheres a step, float16 over structure
 * of arrays), a tile's cone against its group's survivors; each runs twice, first counting the
 * survivors, then, at the offsets the host summed, writing them. Then every ray tests only its
 * tile's survivors (the fragment-unit step), sixteen rays of a tile together, with the routines
 * of intersect.cl or their float16 twin for triangles (lower id wins ties), so the hits equal
 * brute force's. A list of RC_CONES_ALL entries stands for every
 * primitive (an unbounded cone, or a list that did not fit). */
#include "rc_types.h"
#include "intersect.cl"
#include "bvh.cl"
#include "accel_common.cl"

#pragma OPENCL FP_CONTRACT OFF

#define RC_CONES_ALL 0xFFFFFFFFu
#define RC_CONE_TILE_RAYS 64
#define RC_CONE_GROUP_TILES 16

/* Whether spheres (centre c, radius r) meet the cone (Eberly's cone-sphere test: the centre
 * inside the cone grown by r, then the region behind the apex), with angles compared through
 * the perpendicular distance, which keeps its precision in narrow cones. */
inline int16 rc_cone_spheres16(RcCone cone, float16 cx, float16 cy, float16 cz, float16 r) {
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

inline int rc_cone_sphere(RcCone cone, float cx, float cy, float cz, float r) {
    return rc_cone_spheres16(cone, (float16)(cx), (float16)(cy), (float16)(cz), (float16)(r)).s0;
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
inline uint rc_cones_tile_candidates(uint j, __global const uint* tileOffsets,
                                     __global const uint* tileCounts, __global const uint* tileList,
                                     uint nPrims, __global const uint** ids) {
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
inline int16 rc_cones_primitive_lanes(const RcBvhPacket* p, int16 live, uint id,
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
inline uint16 rc_cones_packet(const RcBvhPacket* p, int anyHit, uint count,
                              __global const uint* ids, __global const RcTriangle* triangles,
                              __global const RcSphere* spheres, __global const RcQuadric* quadrics,
                              uint nT, uint nS, float16* bt, uint16* bp, float16* bu, float16* bv,
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
inline void rc_cones_answer(int anyHit, __global const RcRay* sorted, uint first, uint n,
                            __global const uint* order, __global const uint* tileOffsets,
                            __global const uint* tileCounts, __global const uint* tileList,
                            __global const RcTriangle* triangles, __global const RcSphere* spheres,
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
    rc_bvh_load_packet(sorted, first, n, anyHit, INFINITY, &p);
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
