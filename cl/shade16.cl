/* rc_shade's model (cl/shade.cl) with 16 rays a work-item in float16 lanes: PoCL runs a
 * scalar shading kernel one ray at a time, so the lanes are the rays. Every lane does the same
 * operations in the same order as rc_shade_ray, so the results are equal bit for bit: where
 * length, normalize or pow rescale (results or inputs outside the normal range) the lanes that
 * need it take the scalar builtin; hits other than triangles take rc_surface. */
#include "encoding.cl"
#include "intersect.cl"
#include "rc_types.h"
#include "shade.cl"
#include "vec16.cl"

#pragma OPENCL FP_CONTRACT OFF

/* clang-format reflows this macro differently on every run. */
/* clang-format off */
#define RC_FOR_LANES(M)                                                                            \
    M(0, s0)                                                                                       \
    M(1, s1)                                                                                       \
    M(2, s2)                                                                                       \
    M(3, s3)                                                                                       \
    M(4, s4)                                                                                       \
    M(5, s5) M(6, s6) M(7, s7) M(8, s8) M(9, s9) M(10, sa) M(11, sb) M(12, sc) M(13, sd) M(14, se) \
        M(15, sf)
/* clang-format on */

/* The components of 16 float4s as lanes: the float4s concatenated four to a float16 and their
 * components sorted by swizzles, shuffles of whole registers (a lane at a time took an insert
 * per component). */
RC_SHADE_INLINE void rc_transpose16(const float4* a, float16* x, float16* y, float16* z,
                                    float16* w) {
    const float16 q0 = (float16)(a[0], a[1], a[2], a[3]), q1 = (float16)(a[4], a[5], a[6], a[7]),
                  q2 = (float16)(a[8], a[9], a[10], a[11]),
                  q3 = (float16)(a[12], a[13], a[14], a[15]);
    /* .even of a float16 of float4s: x, z, x, z ...; .odd: y, w, y, w ... */
    const float16 xz01 = (float16)(q0.even, q1.even), xz23 = (float16)(q2.even, q3.even);
    const float16 yw01 = (float16)(q0.odd, q1.odd), yw23 = (float16)(q2.odd, q3.odd);
    *x = (float16)(xz01.even, xz23.even);
    *y = (float16)(yw01.even, yw23.even);
    *z = (float16)(xz01.odd, xz23.odd);
    *w = (float16)(yw01.odd, yw23.odd);
}

RC_SHADE_INLINE RcVec16 rc_lanes_xyz(const float4* a) {
    RcVec16 v;
    float16 unused;
    rc_transpose16(a, &v.x, &v.y, &v.z, &unused);
    return v;
}

/* Lanes where a squared length is outside the range in which the builtins compute sqrt of it
 * without rescaling. */
RC_SHADE_INLINE int16 rc_rescaled16(float16 dd) { return !(dd >= FLT_MIN && dd <= FLT_MAX); }

/* The scalar fallbacks below are not inlined: PoCL keeps a kernel's private arrays in
 * per-work-item context arrays, a called function's on its own stack. Vectors go in and out by
 * value; a struct goes through the caller's memory, which becomes a context array. */
#define RC_SCALAR_FALLBACK static __attribute__((noinline))

/* r with the lanes `odd` replaced by the scalar length of (x, y, z) (axis < 0) or by component
 * `axis` of its scalar normalize. */
RC_SCALAR_FALLBACK float16 rc_vec16_scalar(float16 vx, float16 vy, float16 vz, float16 r, int16 odd,
                                           int axis) {
    float x[16], y[16], z[16], out[16];
    int m[16];
    vstore16(vx, 0, x);
    vstore16(vy, 0, y);
    vstore16(vz, 0, z);
    vstore16(r, 0, out);
    vstore16(odd, 0, m);
    for (int k = 0; k < 16; ++k) {
        if (!m[k]) continue;
        const float3 v = (float3)(x[k], y[k], z[k]);
        if (axis < 0) {
            out[k] = length(v);
        } else {
            const float3 u = normalize(v);
            out[k] = axis == 0 ? u.x : axis == 1 ? u.y : u.z;
        }
    }
    return vload16(0, out);
}

RC_SHADE_INLINE float16 rc_length16(RcVec16 v) {
    const float16 dd = rc_v16_dot(v, v);
    const float16 len = sqrt(dd);
    const int16 odd = rc_rescaled16(dd);
    return any(odd) ? rc_vec16_scalar(v.x, v.y, v.z, len, odd, -1) : len;
}

RC_SHADE_INLINE RcVec16 rc_normalize16(RcVec16 v) {
    const float16 dd = rc_v16_dot(v, v);
    const float16 inv = 1.0f / sqrt(dd);
    RcVec16 n = rc_v16_scale(v, inv);
    const int16 odd = rc_rescaled16(dd);
    if (any(odd)) {
        n = rc_v16(rc_vec16_scalar(v.x, v.y, v.z, n.x, odd, 0),
                   rc_vec16_scalar(v.x, v.y, v.z, n.y, odd, 1),
                   rc_vec16_scalar(v.x, v.y, v.z, n.z, odd, 2));
    }
    return n;
}

/* r with the lanes `odd` replaced by the scalar pow(x, y). */
RC_SCALAR_FALLBACK float16 rc_pow16_scalar(float16 x, float16 y, float16 r, int16 odd) {
    float a[16], b[16], c[16];
    int m[16];
    vstore16(x, 0, a);
    vstore16(y, 0, b);
    vstore16(r, 0, c);
    vstore16(odd, 0, m);
    for (int k = 0; k < 16; ++k) {
        if (m[k]) c[k] = pow(a[k], b[k]);
    }
    return vload16(0, c);
}

/* pow of the lanes; the vector pow differs from the scalar one on subnormal results, which
 * those lanes take from the scalar pow. */
RC_SHADE_INLINE float16 rc_pow16(float16 x, float16 y) {
    const float16 r = pow(x, y);
    const int16 odd = r != 0.0f && fabs(r) < FLT_MIN;
    return any(odd) ? rc_pow16_scalar(x, y, r, odd) : r;
}

RC_SHADE_INLINE float16 rc_offset_component16(float16 p, float16 n) {
    const int16 ulps = convert_int16_rtz(256.0f * n);
    const float16 stepped = as_float16(as_int16(p) + select(ulps, -ulps, p < 0.0f));
    return select(stepped, p + (1.0f / 65536.0f) * n, fabs(p) < (1.0f / 32.0f));
}

RC_SHADE_INLINE RcVec16 rc_offset_ray_origin16(RcVec16 p, RcVec16 n) {
    return rc_v16(rc_offset_component16(p.x, n.x), rc_offset_component16(p.y, n.y),
                  rc_offset_component16(p.z, n.z));
}

/* 16 rays' hits and what shading reads of them. */
typedef struct RcShadeLanes {
    RcVec16 d, weight;
    RcVec16 p, ng, ns;
    int16 entering, hit;
    uint16 depth, material;
} RcShadeLanes;

/* rc_surface of the lanes `scalar` (entering and material of the others as given; their p, ng
 * and ns undefined). */
typedef struct RcSurface16 {
    RcVec16 p, ng, ns;
    int16 entering;
    uint16 material;
} RcSurface16;

RC_SCALAR_FALLBACK RcSurface16
rc_surface16_scalar(float16 ox16, float16 oy16, float16 oz16, float16 dx16, float16 dy16,
                    float16 dz16, float16 t, uint16 prim, float16 u, float16 v, int16 scalar,
                    int16 entering16, uint16 material16, __global const RcTriangle* triangles,
                    __global const RcTriangleShading* triShading, __global const RcSphere* spheres,
                    __global const RcQuadric* quadrics, uint nTriangles, uint nSpheres) {
    float4 sp[16], sng[16], sns[16];
    int m[16], entering[16];
    uint material[16], ids[16];
    float ox[16], oy[16], oz[16], dx[16], dy[16], dz[16], ht[16], hu[16], hv[16];
    vstore16(scalar, 0, m);
    vstore16(ox16, 0, ox);
    vstore16(oy16, 0, oy);
    vstore16(oz16, 0, oz);
    vstore16(dx16, 0, dx);
    vstore16(dy16, 0, dy);
    vstore16(dz16, 0, dz);
    vstore16(t, 0, ht);
    vstore16(prim, 0, ids);
    vstore16(u, 0, hu);
    vstore16(v, 0, hv);
    vstore16(entering16, 0, entering);
    vstore16(material16, 0, material);
    for (int k = 0; k < 16; ++k) {
        if (!m[k]) continue;
        RcHit h;
        h.t = ht[k];
        h.prim = ids[k];
        h.u = hu[k];
        h.v = hv[k];
        const RcSurface s =
            rc_surface((float3)(ox[k], oy[k], oz[k]), (float3)(dx[k], dy[k], dz[k]), h, triangles,
                       triShading, spheres, quadrics, nTriangles, nSpheres);
        sp[k] = (float4)(s.p, 0.0f);
        sng[k] = (float4)(s.ng, 0.0f);
        sns[k] = (float4)(s.ns, 0.0f);
        entering[k] = s.entering ? -1 : 0;
        material[k] = s.material;
    }
    RcSurface16 S;
    S.p = rc_lanes_xyz(sp);
    S.ng = rc_lanes_xyz(sng);
    S.ns = rc_lanes_xyz(sns);
    S.entering = vload16(0, entering);
    S.material = vload16(0, material);
    return S;
}

/* The surfaces of the lanes' hits: triangles (vertices p0, p1, p2, vertex normals n0, n1, n2
 * where hasNormals) in the lanes, other primitives by rc_surface. */
RC_SHADE_INLINE void rc_surface16(RcShadeLanes* L, RcVec16 o, float16 t, uint16 prim, float16 u,
                                  float16 v, RcVec16 p0, RcVec16 p1, RcVec16 p2, const float4* n0,
                                  const float4* n1, const float4* n2, int16 hasNormals,
                                  int16 triangle, __global const RcTriangle* triangles,
                                  __global const RcTriangleShading* triShading,
                                  __global const RcSphere* spheres,
                                  __global const RcQuadric* quadrics,
                                  __constant const RcRenderParams* params) {
    /* Lanes where length or normalize would rescale, and hits other than triangles. */
    int16 scalar = L->hit & ~triangle;
    const RcVec16 zero = rc_v16(0.0f, 0.0f, 0.0f);
    L->p = L->ng = L->ns = zero;
    L->entering = 0;
    if (any(L->hit & triangle)) {
        const float16 w = 1.0f - u - v;
        L->p =
            rc_v16_add(rc_v16_add(rc_v16_scale(p0, w), rc_v16_scale(p1, u)), rc_v16_scale(p2, v));
        RcVec16 n = rc_v16_cross(rc_v16_sub(p1, p0), rc_v16_sub(p2, p0));
        const float16 nn = rc_v16_dot(n, n);
        const float16 len = sqrt(nn);
        n = rc_v16_select(rc_v16_neg(L->d), rc_v16(n.x / len, n.y / len, n.z / len), len > 0.0f);
        L->ng = n;
        L->ns = n;
        scalar |= L->hit & rc_rescaled16(nn);
        if (any(hasNormals)) {
            const RcVec16 ni = rc_v16_add(
                rc_v16_add(rc_v16_scale(rc_lanes_xyz(n0), w), rc_v16_scale(rc_lanes_xyz(n1), u)),
                rc_v16_scale(rc_lanes_xyz(n2), v));
            const float16 ii = rc_v16_dot(ni, ni);
            L->ns = rc_v16_select(n, rc_v16_scale(ni, 1.0f / sqrt(ii)), hasNormals);
            scalar |= L->hit & hasNormals & rc_rescaled16(ii);
        }
        L->entering = rc_v16_dot(L->d, L->ng) < 0.0f;
        L->ng = rc_v16_select(rc_v16_neg(L->ng), L->ng, L->entering);
        L->ns = rc_v16_select(L->ns, rc_v16_neg(L->ns), rc_v16_dot(L->ns, L->ng) < 0.0f);
    }
    if (!any(scalar)) return;
    const RcSurface16 S = rc_surface16_scalar(
        o.x, o.y, o.z, L->d.x, L->d.y, L->d.z, t, prim, u, v, scalar, L->entering, L->material,
        triangles, triShading, spheres, quadrics, params->nTriangles, params->nSpheres);
    L->p = rc_v16_select(L->p, S.p, scalar);
    L->ng = rc_v16_select(L->ng, S.ng, scalar);
    L->ns = rc_v16_select(L->ns, S.ns, scalar);
    L->entering = S.entering;
    L->material = S.material;
}

/* The lanes' materials. */
typedef struct RcMaterial16 {
    RcVec16 kd, ks, kr, kt, emission;
    float16 shininess, ior;
    int16 fresnel;
} RcMaterial16;

RC_SHADE_INLINE RcVec16 rc_splat16(float4 a) {
    return rc_v16((float16)(a.x), (float16)(a.y), (float16)(a.z));
}

RC_SHADE_INLINE RcMaterial16 rc_materials16(__global const RcMaterial* materials, uint16 id) {
    RcMaterial16 M;
    if (all(id == id.s0)) {
        /* One material in all lanes, the common case: loaded once. */
        __global const RcMaterial* m = materials + id.s0;
        M.kd = rc_splat16(m->kd);
        M.ks = rc_splat16(m->ks);
        M.kr = rc_splat16(m->kr);
        M.kt = rc_splat16(m->kt);
        M.emission = rc_splat16(m->emission);
        M.shininess = (float16)(m->shininess);
        M.ior = (float16)(m->ior);
        M.fresnel = (int16)(m->fresnel ? -1 : 0);
        return M;
    }
    float4 kd[16], ks[16], kr[16], kt[16], em[16], rest[16];
#define RC_LOAD_MATERIAL(k, s)                                                \
    {                                                                         \
        __global const RcMaterial* m = materials + id.s;                      \
        kd[k] = m->kd;                                                        \
        ks[k] = m->ks;                                                        \
        kr[k] = m->kr;                                                        \
        kt[k] = m->kt;                                                        \
        em[k] = m->emission;                                                  \
        rest[k] = (float4)(m->shininess, m->ior, as_float(m->fresnel), 0.0f); \
    }
    RC_FOR_LANES(RC_LOAD_MATERIAL)
#undef RC_LOAD_MATERIAL
    M.kd = rc_lanes_xyz(kd);
    M.ks = rc_lanes_xyz(ks);
    M.kr = rc_lanes_xyz(kr);
    M.kt = rc_lanes_xyz(kt);
    M.emission = rc_lanes_xyz(em);
    float16 fresnel, unused;
    rc_transpose16(rest, &M.shininess, &M.ior, &fresnel, &unused);
    M.fresnel = as_uint16(fresnel) != 0u;
    return M;
}

RC_SHADE_INLINE float16 rc_fresnel_dielectric16(float16 cosi, float16 eta) {
    const float16 sin2t = eta * eta * (1.0f - cosi * cosi);
    const float16 cost = sqrt(1.0f - sin2t);
    const float16 rs = (eta * cosi - cost) / (eta * cosi + cost);
    const float16 rp = (cosi - eta * cost) / (cosi + eta * cost);
    return select(0.5f * (rs * rs + rp * rp), 1.0f, sin2t >= 1.0f);
}

RC_SHADE_INLINE int16 rc_worth_spawning16(RcVec16 w, uint16 depth,
                                          __constant const RcRenderParams* params) {
    return depth <= params->maxDepth & rc_v16_max3(w) >= params->minWeight;
}

/* A lane's secondary ray into slot `slot`, as rc_spawn writes it (dir already unit). */
#define RC_SPAWN_LANE(slot_, origin_, dir_, weight_, depth_, kind_, s_)                    \
    do {                                                                                   \
        RcRay out_;                                                                        \
        out_.origin = (float4)((origin_).x.s_, (origin_).y.s_, (origin_).z.s_, 0.0f);      \
        out_.direction =                                                                   \
            (float4)(rc_encode_direction((float3)((dir_).x.s_, (dir_).y.s_, (dir_).z.s_)), \
                     INFINITY);                                                            \
        secondary[slot_] = out_;                                                           \
        RcRayInfo info_;                                                                   \
        info_.weight = (float4)((weight_).x.s_, (weight_).y.s_, (weight_).z.s_, 1.0f);     \
        info_.depth = (depth_).s_;                                                         \
        info_.kind = kind_;                                                                \
        info_.pad0 = info_.pad1 = 0;                                                       \
        secondaryInfo[slot_] = info_;                                                      \
    } while (0)

/* Asks the cache for the triangles that the rays [first, first + 16) of the list hit: the work-item
 * after this one shades them, and their records are scattered through memory. */
RC_SHADE_INLINE void rc_prefetch_triangles16(__global const RcHit* hits, __global const uint* ids,
                                             uint first, uint nIds,
                                             __global const RcTriangle* triangles,
                                             __global const RcTriangleShading* triShading,
                                             uint nTriangles) {
    if (first >= nIds) return;
#pragma unroll
    for (uint k = 0; k < 16; ++k) {
        const uint j = min(first + k, nIds - 1);
        const uint prim = hits[ids ? ids[j] : j].prim;
        const uint t = prim < nTriangles ? prim : 0;
        __builtin_prefetch(&triangles[t].v0, 0, 3);
        __builtin_prefetch(&triangles[t].v2, 0, 3);
        __builtin_prefetch(&triShading[t], 0, 3);
    }
}

/* Rays ids[16 g, 16 g + 16) (below nIds) of the batch, or its rays [16 g, 16 g + 16) when ids is
 * null, g the work-item: rc_shade_ray's outputs, lights included. */
RC_SHADE_INLINE void rc_shade16_rays(__global const RcRay* rays, __global const RcRayInfo* infos,
                                     __global const RcHit* hits, __global const uint* ids,
                                     uint nIds, RC_SHADE_SCENE_PARAMS, RC_SHADE_OUT_PARAMS) {
    const uint first = get_global_id(0) * 16;
    if (first >= nIds) return;
    const uint nTriangles = params->nTriangles;
    float4 o[16], d[16], h[16], wgt[16], inf[16], v0[16], v1[16], v2[16], sh[16];
    float4 n0[16], n1[16], n2[16];
    uint ray[16];
    rc_prefetch_triangles16(hits, ids, first + 16, nIds, triangles, triShading, nTriangles);
#pragma unroll
    for (uint k = 0; k < 16; ++k) {
        const uint j = min(first + k, nIds - 1);
        const uint i = ids ? ids[j] : j;
        ray[k] = i;
        o[k] = rays[i].origin;
        d[k] = rays[i].direction;
        const RcHit hit = hits[i];
        h[k] = (float4)(hit.t, as_float(hit.prim), hit.u, hit.v);
        const RcRayInfo info = rc_ray_info(infos, i);
        wgt[k] = info.weight;
        inf[k] = (float4)(as_float(info.depth), 0.0f, 0.0f, 0.0f);
        /* Lanes of other primitives and misses read triangle 0 (there is always one: a zeroed
         * one when the scene has none), which the lanes then ignore. */
        const uint t = hit.prim < nTriangles ? hit.prim : 0;
        v0[k] = triangles[t].v0;
        v1[k] = triangles[t].v1;
        v2[k] = triangles[t].v2;
        sh[k] = (float4)(as_float(triShading[t].material), as_float(triShading[t].hasNormals), 0.0f,
                         0.0f);
        n0[k] = n1[k] = n2[k] = (float4)(0.0f);
        if (triShading[t].hasNormals) {
            n0[k] = triShading[t].n0;
            n1[k] = triShading[t].n1;
            n2[k] = triShading[t].n2;
        }
    }
    RcShadeLanes L;
    L.d = rc_lanes_xyz(d);
    L.weight = rc_lanes_xyz(wgt);
    float16 t, primF, u, v, depthF, materialF, hasNormalsF, unused;
    rc_transpose16(h, &t, &primF, &u, &v);
    const uint16 prim = as_uint16(primF);
    L.hit = prim != RC_NO_HIT;
    rc_transpose16(inf, &depthF, &unused, &unused, &unused);
    L.depth = as_uint16(depthF);
    rc_transpose16(sh, &materialF, &hasNormalsF, &unused, &unused);
    L.material = as_uint16(materialF);
    rc_surface16(&L, rc_lanes_xyz(o), t, prim, u, v, rc_lanes_xyz(v0), rc_lanes_xyz(v1),
                 rc_lanes_xyz(v2), n0, n1, n2, as_uint16(hasNormalsF) != 0u, prim < nTriangles,
                 triangles, triShading, spheres, quadrics, params);
    const RcMaterial16 M = rc_materials16(materials, L.material);
    const RcVec16 kd = M.kd, ks = M.ks, kr = M.kr, kt = M.kt, em = M.emission;

    const float4 amb = params->ambient, bg = params->background;
    RcVec16 rad =
        rc_v16_mul(L.weight, rc_v16_add(em, rc_v16(kd.x * amb.x, kd.y * amb.y, kd.z * amb.z)));
    rad =
        rc_v16_select(rc_v16(L.weight.x * bg.x, L.weight.y * bg.y, L.weight.z * bg.z), rad, L.hit);
#define RC_STORE_RAY(k, s)                                                                        \
    if (first + k < nIds) {                                                                       \
        const uint i = ray[k];                                                                    \
        radiance[i] = (float4)(rad.x.s, rad.y.s, rad.z.s, 0.0f);                                  \
        if (normals) {                                                                            \
            normals[i] = L.hit.s ? (float4)(L.ns.x.s, L.ns.y.s, L.ns.z.s, 0.0f) : (float4)(0.0f); \
        }                                                                                         \
    }
    RC_FOR_LANES(RC_STORE_RAY)
#undef RC_STORE_RAY

    const uint nLights = params->nLights;
    const int16 specular = rc_v16_max3(ks) > 0.0f;
    for (uint l = 0; l < nLights; ++l) {
        const float4 lp = lights[l].position, li = lights[l].intensity;
        const RcVec16 toLight = rc_v16(lp.x - L.p.x, lp.y - L.p.y, lp.z - L.p.z);
        const float16 dist2 = rc_v16_dot(toLight, toLight);
        const float16 r = sqrt(dist2);
        const RcVec16 ldir = rc_v16(toLight.x / r, toLight.y / r, toLight.z / r);
        const float16 cosl = rc_v16_dot(L.ns, ldir);
        int16 live = L.hit & !(cosl <= 0.0f | rc_v16_dot(L.ng, ldir) <= 0.0f);
        RcVec16 brdf = rc_v16(kd.x * cosl, kd.y * cosl, kd.z * cosl);
        if (any(live & specular)) {
            const float16 c2 = 2.0f * cosl;
            const RcVec16 refl = rc_v16_sub(rc_v16_scale(L.ns, c2), ldir);
            const float16 cosb = fmax(rc_v16_dot(refl, rc_v16_neg(L.d)), 0.0f);
            const float16 lobe = rc_pow16(cosb, M.shininess);
            brdf = rc_v16_select(brdf, rc_v16_add(brdf, rc_v16_scale(ks, lobe)), specular);
        }
        const RcVec16 c = rc_v16_mul(
            rc_v16(L.weight.x * li.x / dist2, L.weight.y * li.y / dist2, L.weight.z * li.z / dist2),
            brdf);
        live &= !(rc_v16_max3(c) <= 0.0f);
        const RcVec16 above = rc_offset_ray_origin16(L.p, L.ng);
        const RcVec16 toLightFromOrigin = rc_v16(lp.x - above.x, lp.y - above.y, lp.z - above.z);
        const float16 dist = rc_length16(toLightFromOrigin);
        const RcVec16 dir = rc_v16(toLightFromOrigin.x / dist, toLightFromOrigin.y / dist,
                                   toLightFromOrigin.z / dist);
#define RC_STORE_SHADOW(k, s)                                               \
    if (first + k < nIds) {                                                 \
        const uint slot = ray[k] * nLights + l;                             \
        RcRay sr;                                                           \
        if (live.s) {                                                       \
            sr.origin = (float4)(above.x.s, above.y.s, above.z.s, 0.0f);    \
            sr.direction = (float4)(dir.x.s, dir.y.s, dir.z.s, dist.s);     \
            shadowContribution[slot] = (float4)(c.x.s, c.y.s, c.z.s, 1.0f); \
        } else {                                                            \
            sr.origin = sr.direction = (float4)(0.0f);                      \
            shadowContribution[slot] = (float4)(0.0f);                      \
        }                                                                   \
        shadowRays[slot] = sr;                                              \
    }
        RC_FOR_LANES(RC_STORE_SHADOW)
#undef RC_STORE_SHADOW
    }

    /* Each spawned ray is written in the branch that computes it: a float16 value that left the
     * branch would join its unset path and be kept in PoCL's per-work-item context arrays. */
    const int16 bounces = L.hit & !(fmax(rc_v16_max3(kr), rc_v16_max3(kt)) <= 0.0f);
    int16 reflect = 0, refract = 0;
    const uint16 depth1 = L.depth + 1u;
    if (any(bounces)) {
        const float16 cosi = fmin(fmax(-rc_v16_dot(L.d, L.ns), 0.0f), 1.0f);
        const float16 iorL = M.ior;
        const float16 eta = select(iorL, 1.0f / iorL, L.entering);
        const float16 sin2t = eta * eta * (1.0f - cosi * cosi);
        const int16 tir = sin2t >= 1.0f;
        const int16 fresnelL = M.fresnel;
        const float16 f = rc_fresnel_dielectric16(cosi, eta);
        RcVec16 krEff = rc_v16_select(kr, rc_v16_add(kr, kt), tir);
        RcVec16 ktEff = rc_v16_select(kt, rc_v16(0.0f, 0.0f, 0.0f), tir);
        krEff = rc_v16_select(krEff, rc_v16_add(kr, rc_v16_scale(kt, f)), fresnelL);
        ktEff = rc_v16_select(ktEff, rc_v16_scale(kt, 1.0f - f), fresnelL);
        const RcVec16 wr = rc_v16_mul(L.weight, krEff);
        reflect = bounces & rc_worth_spawning16(wr, depth1, params);
        if (any(reflect)) {
            const float16 c2 = 2.0f * cosi;
            RcVec16 dir = rc_v16_add(L.d, rc_v16_scale(L.ns, c2));
            const float16 dn2 = 2.0f * rc_v16_dot(L.d, L.ng);
            dir = rc_v16_select(dir, rc_v16_sub(L.d, rc_v16_scale(L.ng, dn2)),
                                rc_v16_dot(dir, L.ng) <= 0.0f);
            const RcVec16 rDir = rc_normalize16(dir);
            const RcVec16 rOrigin = rc_offset_ray_origin16(L.p, L.ng);
#define RC_STORE_REFLECTED(k, s)                                              \
    if (first + k < nIds && reflect.s) {                                      \
        const uint slot = RC_SECONDARY_SLOT(ray[k], 0);                       \
        RC_SPAWN_LANE(slot, rOrigin, rDir, wr, depth1, RC_RAY_REFLECTION, s); \
    }
            RC_FOR_LANES(RC_STORE_REFLECTED)
#undef RC_STORE_REFLECTED
        }
        const RcVec16 wt = rc_v16_mul(L.weight, ktEff);
        const RcVec16 dir =
            rc_v16_add(rc_v16_scale(L.d, eta), rc_v16_scale(L.ns, eta * cosi - sqrt(1.0f - sin2t)));
        refract =
            bounces & ~tir & rc_worth_spawning16(wt, depth1, params) & rc_v16_dot(dir, L.ng) < 0.0f;
        if (any(refract)) {
            const RcVec16 tDir = rc_normalize16(dir);
            const RcVec16 tOrigin = rc_offset_ray_origin16(L.p, rc_v16_neg(L.ng));
#define RC_STORE_REFRACTED(k, s)                                              \
    if (first + k < nIds && refract.s) {                                      \
        const uint slot = RC_SECONDARY_SLOT(ray[k], 1);                       \
        RC_SPAWN_LANE(slot, tOrigin, tDir, wt, depth1, RC_RAY_REFRACTION, s); \
    }
            RC_FOR_LANES(RC_STORE_REFRACTED)
#undef RC_STORE_REFRACTED
        }
    }
#define RC_STORE_SPAWNED(k, s)                  \
    if (first + k < nIds) {                     \
        const uint i = ray[k];                  \
        spawned[2 * i] = reflect.s ? 1 : 0;     \
        spawned[2 * i + 1] = refract.s ? 1 : 0; \
    }
    RC_FOR_LANES(RC_STORE_SPAWNED)
#undef RC_STORE_SPAWNED
}

/* The rays ids[0, nIds) of the batch (rc_shade_ids's lists, whose lights this kernel shades too),
 * or its rays [0, nIds) when ids is null (the renderer's shading of the queries that do not
 * shade). One kernel for both: PoCL parses the program's whole bitcode on every load, and a
 * second kernel would carry a second copy of rc_shade16_rays. */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_shade16_ids(
    __global const RcRay* rays, __global const RcRayInfo* infos, __global const RcHit* hits,
    __global const uint* ids, uint nIds, RC_SHADE_SCENE_PARAMS, RC_SHADE_OUT_PARAMS) {
    rc_shade16_rays(rays, infos, hits, ids, nIds, RC_SHADE_SCENE_ARGS, RC_SHADE_OUT_ARGS);
}
