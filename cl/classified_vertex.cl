/* The vertex style of the classified query's kernels (cl/classified.cl): one work-item per ray,
 * the lanes over 16 candidates of its leaf. Apart from classified.cl so that only the programs of
 * frames that can launch it carry its bitcode, which PoCL parses whole at every program load. */
#include "classified.cl"

#pragma OPENCL FP_CONTRACT OFF

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
