/* Szecsi's hierarchical ray engine (include/rayclass/accel/cones.h) as ray queries: the rays of
 * a batch sorted into coherent tiles, each tile and each group of tiles enclosed in a cone. The
 * cull kernels (the paper's vertex-unit step) test primitives' bounding spheres against the
 * cones, a group's cone against every primitive (sixteen spheres a step, float16 over structure
 * of arrays), a tile's cone against its group's survivors; each runs twice, first counting the
 * survivors, then, at the offsets the host summed, writing them. Then every ray tests only its
 * tile's survivors (the fragment-unit step) with the routines of intersect.cl (lower id wins
 * ties), so the hits equal brute force's. A list of RC_CONES_ALL entries stands for every
 * primitive (an unbounded cone, or a list that did not fit). */
#include "rc_types.h"
#include "intersect.cl"

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

/* One work-item per sorted position j: ray order[j]. counters[ray] counts primitive tests. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_intersect_cones(
    __global const RcRay* rays, uint n, __global const uint* order,
    __global const uint* tileOffsets, __global const uint* tileCounts,
    __global const uint* tileList, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global RcHit* hits, __global uint* counters) {
    const uint j = get_global_id(0);
    if (j >= n) return;
    const uint i = order[j];
    const float3 o = rays[i].origin.xyz, d = rays[i].direction.xyz;
    const float tmin = rays[i].origin.w, tmax = rays[i].direction.w;
    const uint nT = params->nTriangles, nS = params->nSpheres;
    const uint nPrims = nT + nS + params->nQuadrics;
    __global const uint* ids;
    const uint count =
        rc_cones_tile_candidates(j, tileOffsets, tileCounts, tileList, nPrims, &ids);
    RcHit best = rc_no_hit(tmax);
    for (uint k = 0; k < count; ++k)
        rc_intersect_primitive(ids ? ids[k] : k, o, d, tmin, tmax, triangles, spheres, quadrics,
                               nT, nS, &best);
    if (best.prim == RC_NO_HIT) best.t = INFINITY;
    hits[i] = best;
    counters[i] = count;
}

/* Any hit before the light ends the search. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_occluded_cones(
    __global const RcRay* rays, uint n, __global const uint* order,
    __global const uint* tileOffsets, __global const uint* tileCounts,
    __global const uint* tileList, __global const RcTriangle* triangles,
    __global const RcSphere* spheres, __global const RcQuadric* quadrics,
    __constant const RcRenderParams* params, __global uchar* blocked, __global uint* counters) {
    const uint j = get_global_id(0);
    if (j >= n) return;
    const uint i = order[j];
    blocked[i] = 0;
    counters[i] = 0;
    /* An empty slot has tmax 0: nothing can block it. */
    if (rays[i].direction.w == 0.0f) return;
    const float3 o = rays[i].origin.xyz, d = rays[i].direction.xyz;
    const float tmin = rays[i].origin.w, tmax = rays[i].direction.w;
    const uint nT = params->nTriangles, nS = params->nSpheres;
    const uint nPrims = nT + nS + params->nQuadrics;
    __global const uint* ids;
    const uint count =
        rc_cones_tile_candidates(j, tileOffsets, tileCounts, tileList, nPrims, &ids);
    RcHit best = rc_no_hit(tmax);
    uint k = 0;
    while (k < count) {
        const int hit = rc_intersect_primitive(ids ? ids[k] : k, o, d, tmin, tmax, triangles,
                                               spheres, quadrics, nT, nS, &best);
        ++k;
        if (hit) {
            blocked[i] = 1;
            break;
        }
    }
    counters[i] = k;
}
