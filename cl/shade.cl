/* Whitted shading of one hit: emission + ambient, one shadow ray per point light carrying the
 * light's contribution (shading happens before the shadow query; the host adds it only when the
 * ray is unblocked), and the reflection and refraction rays with their weights into their
 * secondary slots (RC_SECONDARY_SLOT; spawned[] says which hold a ray). The reference
 * renderer (src/render/reference.cpp) implements the same model in double. */
#include "rc_types.h"
#include "intersect.cl"
#include "encoding.cl"

#pragma OPENCL FP_CONTRACT OFF

/* The shading helpers are forced inline: PoCL left them as calls, and each work-group loop then
 * ran them one work-item at a time instead of across the work-group's lanes. */
#define RC_SHADE_INLINE static __attribute__((always_inline)) inline

typedef struct RcSurface {
    float3 p;      /* hit point */
    float3 ng;     /* unit geometric normal, facing the incoming ray */
    float3 ns;     /* unit shading normal, same side as ng */
    int entering;  /* the ray arrives from the side the geometric normal points to */
    uint material;
} RcSurface;

RC_SHADE_INLINE RcSurface rc_surface(float3 o, float3 d, RcHit hit, __global const RcTriangle* triangles,
                            __global const RcTriangleShading* triShading,
                            __global const RcSphere* spheres, __global const RcQuadric* quadrics,
                            uint nTriangles, uint nSpheres) {
    RcSurface s;
    const uint id = hit.prim;
    if (id < nTriangles) {
        __global const RcTriangle* tri = triangles + id;
        const float3 p0 = tri->v0.xyz, p1 = tri->v1.xyz, p2 = tri->v2.xyz;
        const float w = 1.0f - hit.u - hit.v;
        /* From barycentrics, not o + t d: the error then scales with the vertices, not with t. */
        s.p = w * p0 + hit.u * p1 + hit.v * p2;
        float3 n = cross(p1 - p0, p2 - p0);
        const float len = length(n);
        n = len > 0.0f ? n / len : -d;
        s.ng = n;
        __global const RcTriangleShading* sh = triShading + id;
        /* Only an interpolated normal needs normalizing; every other one is unit already, and a
         * second normalize costs a sqrt and a division per hit, a share of the shading kernels'
         * time that raybench's shade_s shows. */
        s.ns = sh->hasNormals ? normalize(w * sh->n0.xyz + hit.u * sh->n1.xyz + hit.v * sh->n2.xyz)
                              : n;
        s.material = sh->material;
    } else if (id < nTriangles + nSpheres) {
        const float4 cr = spheres[id - nTriangles].centerRadius;
        const float3 rel = o + hit.t * d - cr.xyz;
        s.ng = normalize(rel);
        /* Re-project onto the sphere so the point's error does not grow with t. */
        s.p = cr.xyz + cr.w * s.ng;
        s.ns = s.ng;
        s.material = spheres[id - nTriangles].material;
    } else if (quadrics[id - nTriangles - nSpheres].kind == RC_ANALYTIC_PATCH_BOX) {
        __global const RcPatchBox* box =
            (__global const RcPatchBox*)(quadrics + (id - nTriangles - nSpheres));
        const float3 n = rc_patch_normal_at((__global const float4*)quadrics + box->points,
                                            hit.u, hit.v, &s.p);
        const float len = length(n);
        s.ng = len > 0.0f ? n / len : -d;
        s.ns = s.ng;
        s.material = box->material;
    } else {
        __global const RcQuadric* q = quadrics + (id - nTriangles - nSpheres);
        /* o + t d is off the surface by the root's error, which grows with t and can exceed the
         * spawn offset; one Newton step along the gradient puts the point back on the surface. */
        s.p = o + hit.t * d;
        const float3 g0 = rc_quadric_gradient(q->c0, q->c1, q->c2, s.p);
        const float gg = dot(g0, g0);
        if (gg > 0.0f) s.p -= rc_quadric_value(q->c0, q->c1, q->c2, s.p) / gg * g0;
        const float3 g = rc_quadric_gradient(q->c0, q->c1, q->c2, s.p);
        const float len = length(g);
        s.ng = len > 0.0f ? g / len : -d;
        s.ns = s.ng;
        s.material = q->material;
    }
    s.entering = dot(d, s.ng) < 0.0f;
    if (!s.entering) s.ng = -s.ng;
    if (dot(s.ns, s.ng) < 0.0f) s.ns = -s.ns;
    return s;
}

/* Unpolarised dielectric Fresnel reflectance; eta = n_incident / n_transmitted. 1 on total
 * internal reflection. */
static inline float rc_fresnel_dielectric(float cosi, float eta) {
    const float sin2t = eta * eta * (1.0f - cosi * cosi);
    if (sin2t >= 1.0f) return 1.0f;
    const float cost = sqrt(1.0f - sin2t);
    const float rs = (eta * cosi - cost) / (eta * cosi + cost);
    const float rp = (cosi - eta * cost) / (cosi + eta * cost);
    return 0.5f * (rs * rs + rp * rp);
}

static inline int rc_worth_spawning(float3 w, uint depth, __constant const RcRenderParams* params) {
    return depth <= params->maxDepth && fmax(w.x, fmax(w.y, w.z)) >= params->minWeight;
}

/* The scene every shading step reads and the outputs it writes, as parameter and argument
 * lists, so the fused query-and-shade kernels (cl/classified.cl) pass them on unchanged. */
#define RC_SHADE_SCENE_PARAMS                                                               \
    __global const RcTriangle *triangles, __global const RcTriangleShading *triShading,    \
        __global const RcSphere *spheres, __global const RcQuadric *quadrics,              \
        __global const RcMaterial *materials, __global const RcLight *lights,              \
        __constant const RcRenderParams *params
#define RC_SHADE_SCENE_ARGS \
    triangles, triShading, spheres, quadrics, materials, lights, params
#define RC_SHADE_OUT_PARAMS                                                          \
    __global float4 *radiance, __global float4 *normals, __global RcRay *shadowRays, \
        __global float4 *shadowContribution, __global RcRay *secondary,              \
        __global RcRayInfo *secondaryInfo, __global uchar *spawned
#define RC_SHADE_OUT_ARGS \
    radiance, normals, shadowRays, shadowContribution, secondary, secondaryInfo, spawned

/* Ray i's info, or an eye ray's when the batch has no info buffer (eye rays get none: see
 * RcRayInfo). */
RC_SHADE_INLINE RcRayInfo rc_ray_info(__global const RcRayInfo* infos, uint i) {
    if (infos) return infos[i];
    RcRayInfo eye;
    eye.weight = (float4)(1.0f);
    eye.depth = 0;
    eye.kind = RC_RAY_EYE;
    eye.pad0 = eye.pad1 = 0;
    return eye;
}

/* An empty shadow slot: no contribution and no direction, so a host classifying every slot
 * finds it missing the scene at once. */
RC_SHADE_INLINE void rc_no_shadow(__global RcRay* shadowRays, __global float4* shadowContribution,
                                  uint slot) {
    RcRay none;
    none.origin = (float4)(0.0f);
    none.direction = (float4)(0.0f);
    shadowRays[slot] = none;
    shadowContribution[slot] = (float4)(0.0f);
}

/* Light l's contribution at the hit of ray i, into shadow slot i * nLights + l (an empty slot
 * when the light is behind the surface or adds nothing). */
RC_SHADE_INLINE void rc_shade_light(uint i, uint l, const RcRay* ray, const RcRayInfo* info,
                                    const RcSurface* s, __global const RcMaterial* m,
                                    __global const RcLight* lights,
                                    __constant const RcRenderParams* params,
                                    __global RcRay* shadowRays,
                                    __global float4* shadowContribution) {
    const uint slot = i * params->nLights + l;
    const float3 d = ray->direction.xyz;
    const float3 toLight = lights[l].position.xyz - s->p;
    const float dist2 = dot(toLight, toLight);
    const float3 ldir = toLight / sqrt(dist2);
    const float cosl = dot(s->ns, ldir);
    if (cosl <= 0.0f || dot(s->ng, ldir) <= 0.0f) {
        rc_no_shadow(shadowRays, shadowContribution, slot);
        return;
    }
    const float3 ks = m->ks.xyz;
    float3 brdf = m->kd.xyz * cosl;
    /* pow is the costliest call of shading on a CPU device: skip it for matte surfaces. */
    if (fmax(ks.x, fmax(ks.y, ks.z)) > 0.0f) {
        const float3 r = 2.0f * cosl * s->ns - ldir;
        const float cosb = fmax(dot(r, -d), 0.0f);
        brdf += ks * pow(cosb, m->shininess);
    }
    const float3 c = info->weight.xyz * lights[l].intensity.xyz / dist2 * brdf;
    if (fmax(c.x, fmax(c.y, c.z)) <= 0.0f) {
        rc_no_shadow(shadowRays, shadowContribution, slot);
        return;
    }
    const float3 above = rc_offset_ray_origin(s->p, s->ng);
    const float3 toLightFromOrigin = lights[l].position.xyz - above;
    const float dist = length(toLightFromOrigin);
    RcRay sr;
    sr.origin = (float4)(above, 0.0f);
    sr.direction = (float4)(toLightFromOrigin / dist, dist);
    shadowRays[slot] = sr;
    shadowContribution[slot] = (float4)(c, 1.0f);
}

/* Writes ray i's secondary ray k (direction dir, not yet unit) into its slot and flags it. */
RC_SHADE_INLINE void rc_spawn(__global RcRay* secondary, __global RcRayInfo* secondaryInfo,
                              __global uchar* spawned, uint i, uint k, float3 origin, float3 dir,
                              float3 weight, uint depth, uint kind) {
    const uint slot = RC_SECONDARY_SLOT(i, k);
    RcRay out;
    out.origin = (float4)(origin, 0.0f);
    out.direction = (float4)(rc_encode_direction(normalize(dir)), INFINITY);
    secondary[slot] = out;
    RcRayInfo outInfo;
    outInfo.weight = (float4)(weight, 1.0f);
    outInfo.depth = depth;
    outInfo.kind = kind;
    outInfo.pad0 = outInfo.pad1 = 0;
    secondaryInfo[slot] = outInfo;
    spawned[2 * i + k] = 1;
}

/* Shades the hit of ray i: radiance, normal (unless `normals` is null), every light's shadow
 * slot, and the reflection and refraction rays. */
RC_SHADE_INLINE void rc_shade_ray(uint i, const RcRay* ray, const RcRayInfo* info, RcHit hit,
                                  RC_SHADE_SCENE_PARAMS, RC_SHADE_OUT_PARAMS) {
    const uint nLights = params->nLights;
    const float3 weight = info->weight.xyz;
    spawned[2 * i] = 0;
    spawned[2 * i + 1] = 0;
    if (hit.prim == RC_NO_HIT) {
        radiance[i] = (float4)(weight * params->background.xyz, 0.0f);
        if (normals) normals[i] = (float4)(0.0f);
        for (uint l = 0; l < nLights; ++l)
            rc_no_shadow(shadowRays, shadowContribution, i * nLights + l);
        return;
    }
    const float3 o = ray->origin.xyz, d = ray->direction.xyz;
    const RcSurface s = rc_surface(o, d, hit, triangles, triShading, spheres, quadrics,
                                   params->nTriangles, params->nSpheres);
    __global const RcMaterial* m = materials + s.material;
    radiance[i] = (float4)(weight * (m->emission.xyz + m->kd.xyz * params->ambient.xyz), 0.0f);
    if (normals) normals[i] = (float4)(s.ns, 0.0f);
    for (uint l = 0; l < nLights; ++l)
        rc_shade_light(i, l, ray, info, &s, m, lights, params, shadowRays, shadowContribution);

    const float3 kr = m->kr.xyz, kt = m->kt.xyz;
    if (fmax(fmax(kr.x, fmax(kr.y, kr.z)), fmax(kt.x, fmax(kt.y, kt.z))) <= 0.0f) return;
    const float cosi = fmin(fmax(-dot(d, s.ns), 0.0f), 1.0f);
    const float eta = s.entering ? 1.0f / m->ior : m->ior;
    const float sin2t = eta * eta * (1.0f - cosi * cosi);
    const int tir = sin2t >= 1.0f;
    float3 krEff = kr, ktEff = kt;
    if (m->fresnel) {
        const float f = rc_fresnel_dielectric(cosi, eta);
        krEff = kr + kt * f;
        ktEff = kt * (1.0f - f);
    } else if (tir) {
        krEff = kr + kt;
        ktEff = (float3)(0.0f);
    }
    const uint depth = info->depth + 1;
    const float3 wr = weight * krEff;
    if (rc_worth_spawning(wr, depth, params)) {
        float3 rdir = d + 2.0f * cosi * s.ns;
        /* A shading normal can tilt the mirror direction below the surface: fall back to ng. */
        if (dot(rdir, s.ng) <= 0.0f) rdir = d - 2.0f * dot(d, s.ng) * s.ng;
        rc_spawn(secondary, secondaryInfo, spawned, i, 0, rc_offset_ray_origin(s.p, s.ng), rdir,
                 wr, depth, RC_RAY_REFLECTION);
    }
    const float3 wt = weight * ktEff;
    if (!tir && rc_worth_spawning(wt, depth, params)) {
        const float3 tdir = eta * d + (eta * cosi - sqrt(1.0f - sin2t)) * s.ns;
        if (dot(tdir, s.ng) < 0.0f) {
            rc_spawn(secondary, secondaryInfo, spawned, i, 1, rc_offset_ray_origin(s.p, -s.ng),
                     tdir, wt, depth, RC_RAY_REFRACTION);
        }
    }
}
