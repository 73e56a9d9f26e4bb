// OpenCL source of raybench --micro's kernel variants (bench only; the renderer's kernels are in
// cl/): one ray per work-item against every primitive, primitives in SoA arrays
// (prims[k * nPrims + i] = component k of primitive i, nPrims a multiple of 16). Per primitive
// type four variants of the same formulas as cl/intersect.cl:
//   scalar_branch  one primitive at a time, early exits (the renderer's style)
//   scalar_select  one primitive at a time, every step computed, the hit chosen by select()
//   vec16_branch   16 primitives in float16 lanes, a block skipped when no lane passes the
//                  first rejection test (discriminant or u)
//   vec16_select   16 primitives in float16 lanes, no branch at all
// Every variant keeps the nearest hit (t, id) per ray; `hits` counts rays with a hit.
#pragma once

namespace rayclass::bench {

inline constexpr const char* kMicroSource = R"CL(
#pragma OPENCL FP_CONTRACT OFF
#define P(k) (prims + (k) * nPrims)

/* Sphere (cx, cy, cz, r): the cancellation-free discriminant of cl/intersect.cl. T is float or
 * float16, the mask type TI int or int16 (comparisons give 1 or -1, both true under select). */
#define SPHERE(T, TI, CX, CY, CZ, R, TMAX, THIT, HIT, EARLY)                                   \
    {                                                                                          \
        const T fx = ox - (CX), fy = oy - (CY), fz = oz - (CZ), r = (R);                       \
        const T b = -(fx * dx + fy * dy + fz * dz);                                           \
        const T lx = fx + (b / a) * dx, ly = fy + (b / a) * dy, lz = fz + (b / a) * dz;        \
        const T disc = a * (r * r - (lx * lx + ly * ly + lz * lz));                            \
        EARLY(disc >= 0.0f);                                                                   \
        const T c = fx * fx + fy * fy + fz * fz - r * r;                                       \
        const T q = b + copysign(sqrt(fmax(disc, 0.0f)), b);                                   \
        const T ta = c / q, tb = q / a;                                                        \
        const T t0 = fmin(ta, tb), t1 = fmax(ta, tb);                                          \
        const TI ok0 = (t0 > tmin) & (t0 < (TMAX)), ok1 = (t1 > tmin) & (t1 < (TMAX));         \
        THIT = select(t1, t0, ok0);                                                            \
        HIT = (disc >= 0.0f) & (ok0 | ok1);                                                    \
    }

/* Triangle (v0, e1, e2): Moeller-Trumbore. */
#define TRIANGLE(T, TI, V0X, V0Y, V0Z, E1X, E1Y, E1Z, E2X, E2Y, E2Z, TMAX, THIT, HIT, EARLY)    \
    {                                                                                          \
        const T e1x = (E1X), e1y = (E1Y), e1z = (E1Z), e2x = (E2X), e2y = (E2Y), e2z = (E2Z);  \
        const T pvx = dy * e2z - e2y * dz, pvy = dz * e2x - e2z * dx, pvz = dx * e2y - e2x * dy; \
        const T det = e1x * pvx + e1y * pvy + e1z * pvz;                                       \
        const T inv = 1.0f / det;                                                              \
        const T tvx = ox - (V0X), tvy = oy - (V0Y), tvz = oz - (V0Z);                          \
        const T u = (tvx * pvx + tvy * pvy + tvz * pvz) * inv;                                 \
        EARLY((u >= 0.0f) & (u <= 1.0f));                                                      \
        const T qx = tvy * e1z - e1y * tvz, qy = tvz * e1x - e1z * tvx,                        \
                qz = tvx * e1y - e1x * tvy;                                                    \
        const T v = (dx * qx + dy * qy + dz * qz) * inv;                                       \
        THIT = (e2x * qx + e2y * qy + e2z * qz) * inv;                                         \
        HIT = (det != 0.0f) & (u >= 0.0f) & (u <= 1.0f) & (v >= 0.0f) & (u + v <= 1.0f) &      \
              (THIT > tmin) & (THIT < (TMAX));                                                 \
    }

/* Quadric (10 coefficients, box min, box max): the nearer root in the clip box, else the
 * farther one. a == 0 (a plane-like quadric along the ray) is not handled: no hit. */
#define QUADRIC(T, TI, LOAD, TMAX, THIT, HIT, EARLY)                                           \
    {                                                                                          \
        const T A = LOAD(0), B = LOAD(1), C = LOAD(2), D = LOAD(3), E = LOAD(4), F = LOAD(5),  \
                G = LOAD(6), H = LOAD(7), I = LOAD(8), J = LOAD(9);                           \
        const T qa = A * dx * dx + B * dy * dy + C * dz * dz + D * dx * dy + E * dx * dz +      \
                     F * dy * dz;                                                              \
        const T qb = 2.0f * (A * ox * dx + B * oy * dy + C * oz * dz) + D * (ox * dy + oy * dx) + \
                     E * (ox * dz + oz * dx) + F * (oy * dz + oz * dy) + G * dx + H * dy +      \
                     I * dz;                                                                   \
        const T qc = A * ox * ox + B * oy * oy + C * oz * oz + D * ox * oy + E * ox * oz +      \
                     F * oy * oz + G * ox + H * oy + I * oz + J;                               \
        const T disc = qb * qb - 4.0f * qa * qc;                                               \
        EARLY(disc >= 0.0f);                                                                   \
        const T qq = -0.5f * (qb + copysign(sqrt(fmax(disc, 0.0f)), qb));                      \
        const T ra = qq / qa, rb = qc / qq;                                                    \
        const T r0 = fmin(ra, rb), r1 = fmax(ra, rb);                                          \
        const T lox = LOAD(10), loy = LOAD(11), loz = LOAD(12);                                \
        const T hix = LOAD(13), hiy = LOAD(14), hiz = LOAD(15);                                \
        const T x0 = ox + r0 * dx, y0 = oy + r0 * dy, z0 = oz + r0 * dz;                       \
        const T x1 = ox + r1 * dx, y1 = oy + r1 * dy, z1 = oz + r1 * dz;                       \
        const TI in0 = (r0 > tmin) & (r0 < (TMAX)) & (x0 >= lox) & (x0 <= hix) & (y0 >= loy) & \
                       (y0 <= hiy) & (z0 >= loz) & (z0 <= hiz);                                \
        const TI in1 = (r1 > tmin) & (r1 < (TMAX)) & (x1 >= lox) & (x1 <= hix) & (y1 >= loy) & \
                       (y1 <= hiy) & (z1 >= loz) & (z1 <= hiz);                                \
        THIT = select(r1, r0, in0);                                                            \
        HIT = (disc >= 0.0f) & (qa != 0.0f) & (in0 | in1);                                     \
    }

#define RAY_SETUP                                                                              \
    const uint i = get_global_id(0);                                                           \
    if (i >= nRays) return;                                                                    \
    const float ox = orig[i].x, oy = orig[i].y, oz = orig[i].z;                                \
    const float dx = dir[i].x, dy = dir[i].y, dz = dir[i].z;                                   \
    const float a = dx * dx + dy * dy + dz * dz;                                               \
    const float tmin = 0.0f;                                                                   \
    (void)a;

#define NO_EARLY(c)
#define EARLY_SCALAR(c) \
    if (!(c)) continue;
#define EARLY_VEC(c) \
    if (!any(c)) continue;

#define SCALAR_KERNEL(NAME, EARLY, TEST)                                                       \
    __kernel void NAME(__global const float4* orig, __global const float4* dir, uint nRays,    \
                       __global const float* prims, uint nPrims, __global float* outT,          \
                       __global uint* outId) {                                                 \
        RAY_SETUP                                                                              \
        float best = INFINITY;                                                                 \
        uint bestId = 0xffffffffu;                                                             \
        for (uint p = 0; p < nPrims; ++p) {                                                    \
            float t;                                                                           \
            int hit;                                                                           \
            TEST(float, int, best, t, hit, EARLY)                                           \
            best = select(best, t, hit);                                                       \
            bestId = select(bestId, p, (uint)hit);                                             \
        }                                                                                      \
        outT[i] = best;                                                                        \
        outId[i] = bestId;                                                                     \
    }

#define VEC_KERNEL(NAME, EARLY, TEST)                                                          \
    __kernel void NAME(__global const float4* orig, __global const float4* dir, uint nRays,    \
                       __global const float* prims, uint nPrims, __global float* outT,          \
                       __global uint* outId) {                                                 \
        RAY_SETUP                                                                              \
        float16 best = (float16)(INFINITY);                                                    \
        uint16 bestId = (uint16)(0xffffffffu);                                                 \
        const uint16 lane = (uint16)(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);    \
        for (uint p = 0; p < nPrims; p += 16) {                                                \
            float16 t;                                                                         \
            int16 hit;                                                                         \
            TEST(float16, int16, best, t, hit, EARLY)                                  \
            best = select(best, t, hit);                                                       \
            bestId = select(bestId, lane + p, as_uint16(hit));                                 \
        }                                                                                      \
        float bt = INFINITY;                                                                   \
        uint bi = 0xffffffffu;                                                                 \
        for (int k = 0; k < 16; ++k) {                                                         \
            const float tk = ((float*)&best)[k];                                               \
            const uint ik = ((uint*)&bestId)[k];                                               \
            if (tk < bt || (tk == bt && ik < bi)) {                                            \
                bt = tk;                                                                       \
                bi = ik;                                                                       \
            }                                                                                  \
        }                                                                                      \
        outT[i] = bt;                                                                          \
        outId[i] = bi;                                                                         \
    }

#define S1(k) P(k)[p]
#define V16(k) vload16(p / 16, P(k))
#define SPHERE_S(T, TI, TMAX, THIT, HIT, EARLY) \
    SPHERE(T, TI, S1(0), S1(1), S1(2), S1(3), TMAX, THIT, HIT, EARLY)
#define SPHERE_V(T, TI, TMAX, THIT, HIT, EARLY) \
    SPHERE(T, TI, V16(0), V16(1), V16(2), V16(3), TMAX, THIT, HIT, EARLY)
#define TRIANGLE_S(T, TI, TMAX, THIT, HIT, EARLY)                                           \
    TRIANGLE(T, TI, S1(0), S1(1), S1(2), S1(3), S1(4), S1(5), S1(6), S1(7), S1(8), TMAX, THIT, \
             HIT, EARLY)
#define TRIANGLE_V(T, TI, TMAX, THIT, HIT, EARLY)                                           \
    TRIANGLE(T, TI, V16(0), V16(1), V16(2), V16(3), V16(4), V16(5), V16(6), V16(7), V16(8),    \
             TMAX, THIT, HIT, EARLY)
#define QUADRIC_S(T, TI, TMAX, THIT, HIT, EARLY) QUADRIC(T, TI, S1, TMAX, THIT, HIT, EARLY)
#define QUADRIC_V(T, TI, TMAX, THIT, HIT, EARLY) QUADRIC(T, TI, V16, TMAX, THIT, HIT, EARLY)

SCALAR_KERNEL(sphere_scalar_branch, EARLY_SCALAR, SPHERE_S)
SCALAR_KERNEL(sphere_scalar_select, NO_EARLY, SPHERE_S)
VEC_KERNEL(sphere_vec16_branch, EARLY_VEC, SPHERE_V)
VEC_KERNEL(sphere_vec16_select, NO_EARLY, SPHERE_V)
SCALAR_KERNEL(triangle_scalar_branch, EARLY_SCALAR, TRIANGLE_S)
SCALAR_KERNEL(triangle_scalar_select, NO_EARLY, TRIANGLE_S)
VEC_KERNEL(triangle_vec16_branch, EARLY_VEC, TRIANGLE_V)
VEC_KERNEL(triangle_vec16_select, NO_EARLY, TRIANGLE_V)
SCALAR_KERNEL(quadric_scalar_branch, EARLY_SCALAR, QUADRIC_S)
SCALAR_KERNEL(quadric_scalar_select, NO_EARLY, QUADRIC_S)
VEC_KERNEL(quadric_vec16_branch, EARLY_VEC, QUADRIC_V)
VEC_KERNEL(quadric_vec16_select, NO_EARLY, QUADRIC_V)
)CL";

}  // namespace rayclass::bench
