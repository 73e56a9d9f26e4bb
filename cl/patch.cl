/* Ray-patch intersection by Newton iteration (Martin, Cohen, Fish and Shirley 2000, "Practical
 * Ray Tracing of Trimmed NURBS Surfaces"): the ray as the meet of two planes, the patch box's
 * control points as their signed distances (a, b) from the two planes, and Newton's method on
 * F(u, v) = (a(u, v), b(u, v)) / w(u, v) = 0 from the box's parameter centre. A singular Jacobian
 * moves (u, v) by a fixed step towards the centre; the iteration stops when |F| < eps (a hit
 * when (u, v) is the box's own), when |F| grows (divergence) or at RC_PATCH_ITERATIONS. When the
 * search from the centre ends without converging, more start from the centres of the box's
 * quarters whose control points' hull the ray meets (RC_PATCH_STARTS) and the nearest of their
 * hits counts (a root that is not a hit, outside the box or before tmin like a secondary ray's
 * own origin, ends the test as before: restarts there found next to nothing for their cost): from the
 * centre alone Newton misses the roots of strongly curved boxes seen at a slant, which only a
 * split into many more boxes would otherwise find, and a box seen at a slant can hold two roots. The float16 twin rc_packet_patch (classified.cl's fragment style),
 * the host twin (geometry/patch_intersect.h) and the raster pass's fragment shader
 * (raster/patch_shaders.cpp) do the same operations lane by lane. */
#include "rc_types.h"

#pragma OPENCL FP_CONTRACT OFF

#define RC_PATCH_ITERATIONS 12
/* |F| below this share of the control points' spread around the ray is a hit. */
#define RC_PATCH_EPS (1.0f / 262144.0f)

/* The two planes through the ray (unit normals n1, n2, both orthogonal to d). */
static inline void rc_patch_planes(float3 d, float3* n1, float3* n2) {
    float3 n = fabs(d.x) > fabs(d.y) && fabs(d.x) > fabs(d.z) ? (float3)(d.y, -d.x, 0.0f)
                                                              : (float3)(0.0f, d.z, -d.y);
    n = n / sqrt(RC_DOT3(n, n));
    *n1 = n;
    *n2 = RC_CROSS3(d, n);
}

/* Defines `qualifiers void name(T s, T* b, T* db)`: cubic Bernstein weights b and their
 * derivatives db at s, for T float here and float16 in the packets (patch_packet.cl), one body
 * for both so that a lane computes what the scalar routine computes. */
#define RC_DEFINE_BERNSTEIN3(qualifiers, name, T) \
    qualifiers void name(T s, T* b, T* db) {      \
        const T r = 1.0f - s;                     \
        b[0] = r * r * r;                         \
        b[1] = 3.0f * s * r * r;                  \
        b[2] = 3.0f * s * s * r;                  \
        b[3] = s * s * s;                         \
        db[0] = -3.0f * r * r;                    \
        db[1] = 3.0f * r * (r - 2.0f * s);        \
        db[2] = 3.0f * s * (2.0f * r - s);        \
        db[3] = 3.0f * s * s;                     \
    }

RC_DEFINE_BERNSTEIN3(static inline, rc_bernstein3, float)

/* Value and derivatives of one channel c[16] at the weights (bu, dbu) x (bv, dbv). */
static inline float3 rc_patch_channel(const float* c, const float* bu, const float* dbu,
                                      const float* bv, const float* dbv) {
    float x = 0.0f, xs = 0.0f, xt = 0.0f;
    for (int i = 0; i < 4; ++i) {
        const float row =
            bv[0] * c[4 * i] + bv[1] * c[4 * i + 1] + bv[2] * c[4 * i + 2] + bv[3] * c[4 * i + 3];
        const float rowD = dbv[0] * c[4 * i] + dbv[1] * c[4 * i + 1] + dbv[2] * c[4 * i + 2] +
                           dbv[3] * c[4 * i + 3];
        x += bu[i] * row;
        xs += dbu[i] * row;
        xt += bu[i] * rowD;
    }
    return (float3)(x, xs, xt);
}

/* How one Newton search ended (--stats, cl/patch_stats.cl): the ray missed the control points'
 * hull, |F| fell below eps, |F| grew, (u, v) left the window around the box, or the cap. */
#define RC_NEWTON_CULLED 0
#define RC_NEWTON_CONVERGED 1
#define RC_NEWTON_DIVERGED 2
#define RC_NEWTON_LEFT 3
#define RC_NEWTON_CAP 4

/* Newton's starting points in a box's local (u, v): start 0 at its centre, starts 1 to 4 at its
 * quarters' centres, (1/4, 1/4), (3/4, 1/4), (1/4, 3/4), (3/4, 3/4). */
#define RC_PATCH_STARTS 5
#define RC_PATCH_START_S(k) ((k) == 0 ? 0.5f : ((k) & 1) ? 0.25f : 0.75f)
#define RC_PATCH_START_T(k) ((k) == 0 ? 0.5f : (k) <= 2 ? 0.25f : 0.75f)

/* One Newton search on the projected channels from (*s, *t): how it ended (RC_NEWTON_*, never
 * culled) after *steps updates; (*s, *t) and the weights are those of the last point evaluated. */
static inline int rc_patch_newton_search(const float* a, const float* b, const float* w, float eps,
                                         float* sIo, float* tIo, float* bu, float* dbu, float* bv,
                                         float* dbv, int* steps) {
    float s = *sIo, t = *tIo, prev = INFINITY;
    int outcome;
    for (int it = 0;; ++it) {
        rc_bernstein3(s, bu, dbu);
        rc_bernstein3(t, bv, dbv);
        const float3 A = rc_patch_channel(a, bu, dbu, bv, dbv);
        const float3 B = rc_patch_channel(b, bu, dbu, bv, dbv);
        const float3 W = rc_patch_channel(w, bu, dbu, bv, dbv);
        const float f1 = A.x / W.x, f2 = B.x / W.x;
        const float err = fmax(fabs(f1), fabs(f2));
        *steps = it;
        if (err < eps) {
            outcome = RC_NEWTON_CONVERGED;
            break;
        }
        if (!(err <= prev) || it == RC_PATCH_ITERATIONS) {
            outcome = it == RC_PATCH_ITERATIONS ? RC_NEWTON_CAP : RC_NEWTON_DIVERGED;
            break;
        }
        prev = err;
        const float j11 = (A.y - f1 * W.y) / W.x, j12 = (A.z - f1 * W.z) / W.x;
        const float j21 = (B.y - f2 * W.y) / W.x, j22 = (B.z - f2 * W.z) / W.x;
        const float det = j11 * j22 - j12 * j21;
        if (fabs(det) > 1e-7f * (fabs(j11 * j22) + fabs(j12 * j21))) {
            s -= (j22 * f1 - j12 * f2) / det;
            t -= (j11 * f2 - j21 * f1) / det;
        } else {
            s += s <= 0.5f ? 0.125f : -0.125f;
            t += t <= 0.5f ? 0.0625f : -0.0625f;
            prev = INFINITY;
        }
        if (!(s > -0.5f && s < 1.5f && t > -0.5f && t < 1.5f)) {
            outcome = RC_NEWTON_LEFT;
            *steps = it + 1;
            break;
        }
    }
    *sIo = s;
    *tIo = t;
    return outcome;
}

/* Defines `qualifiers void name(T c0, T c1, T c2, T c3, int upper, T* q)`: one half of the
 * cubic curve (c0, c1, c2, c3) by de Casteljau, the half towards c3 when `upper`, else the half
 * towards c0; T float here and float16 in the packets, as RC_DEFINE_BERNSTEIN3. */
#define RC_DEFINE_HALF_CURVE(qualifiers, name, T)                                        \
    qualifiers void name(T c0, T c1, T c2, T c3, int upper, T* q) {                       \
        const T a = 0.5f * (c0 + c1), b = 0.5f * (c1 + c2), d = 0.5f * (c2 + c3);         \
        const T ab = 0.5f * (a + b), bd = 0.5f * (b + d), m = 0.5f * (ab + bd);           \
        q[0] = upper ? m : c0;                                                            \
        q[1] = upper ? bd : a;                                                            \
        q[2] = upper ? d : ab;                                                            \
        q[3] = upper ? c3 : m;                                                            \
    }

RC_DEFINE_HALF_CURVE(static inline, rc_patch_half_curve, float)

/* Whether channel x of the box's quarter (qu, qv) (1: the upper half of u, of v) takes both signs
 * on the quarter's control points, zero counting as either: where it does not for a or b, the ray
 * misses the quarter's hull and a restart there is spared. */
static inline int rc_patch_quarter_straddles(const float* x, int qu, int qv) {
    float h[16];
    for (int j = 0; j < 4; ++j) {
        float q[4];
        rc_patch_half_curve(x[j], x[4 + j], x[8 + j], x[12 + j], qu, q);
        for (int i = 0; i < 4; ++i) h[4 * i + j] = q[i];
    }
    int signs = 0;
    for (int i = 0; i < 4; ++i) {
        float q[4];
        rc_patch_half_curve(h[4 * i], h[4 * i + 1], h[4 * i + 2], h[4 * i + 3], qv, q);
        for (int j = 0; j < 4; ++j) signs |= (q[j] >= 0.0f ? 1 : 0) | (q[j] <= 0.0f ? 2 : 0);
    }
    return signs == 3;
}

/* rc_intersect_patch_box, also telling how the search from the box's centre ended and after how
 * many Newton steps, and the steps of the restarts in all (-1: none ran). */
static inline int rc_patch_box_newton(float3 o, float3 d, float tmin, float tmax,
                                      __global const float4* analytic,
                                      __global const RcPatchBox* box, float* tOut, float* uOut,
                                      float* vOut, int* outcome, int* steps, int* restartSteps) {
    float3 n1, n2;
    rc_patch_planes(d, &n1, &n2);
    __global const float4* pts = analytic + box->points;
    float a[16], b[16], w[16];
    float spread = 0.0f, wMin = INFINITY;
    int signs = 0;
    for (int k = 0; k < 16; ++k) {
        const float4 p = pts[k];
        const float3 r = p.xyz - o * p.w;
        a[k] = RC_DOT3(n1, r);
        b[k] = RC_DOT3(n2, r);
        w[k] = p.w;
        spread = fmax(spread, fabs(a[k]) + fabs(b[k]));
        wMin = fmin(wMin, p.w);
        signs |= (a[k] > 0.0f ? 1 : 0) | (a[k] < 0.0f ? 2 : 0) | (b[k] > 0.0f ? 4 : 0) |
                 (b[k] < 0.0f ? 8 : 0);
    }
    *outcome = RC_NEWTON_CULLED;
    *steps = 0;
    *restartSteps = -1;
    /* All control points on one side of a plane: the ray misses the convex hull. */
    if ((signs & 3) != 3 || (signs & 12) != 12) return 0;
    const float eps = spread / wMin * RC_PATCH_EPS;
    float c[16];
    for (int k = 0; k < 16; ++k) {
        const float4 p = pts[k];
        const float3 r = p.xyz - o * p.w;
        c[k] = RC_DOT3(d, r);
    }
    int found = 0, centreConverged = 0;
    float nearest = tmax;
    for (int start = 0; start < RC_PATCH_STARTS && !centreConverged; ++start) {
        float s = RC_PATCH_START_S(start), t = RC_PATCH_START_T(start);
        if (start > 0 && !(rc_patch_quarter_straddles(a, s > 0.5f, t > 0.5f) &&
                           rc_patch_quarter_straddles(b, s > 0.5f, t > 0.5f))) {
            continue;
        }
        float bu[4], dbu[4], bv[4], dbv[4];
        int searchSteps;
        const int ending =
            rc_patch_newton_search(a, b, w, eps, &s, &t, bu, dbu, bv, dbv, &searchSteps);
        if (start == 0) {
            *outcome = ending;
            *steps = searchSteps;
        } else {
            *restartSteps = max(*restartSteps, 0) + searchSteps;
        }
        if (ending != RC_NEWTON_CONVERGED) continue;
        centreConverged = start == 0;
        if (!(s >= 0.0f && (s < 1.0f || (box->closedU && s == 1.0f)))) continue;
        if (!(t >= 0.0f && (t < 1.0f || (box->closedV && t == 1.0f)))) continue;
        const float3 C = rc_patch_channel(c, bu, dbu, bv, dbv);
        const float3 W = rc_patch_channel(w, bu, dbu, bv, dbv);
        const float th = C.x / W.x;
        if (!(th > tmin && th < nearest)) continue;
        nearest = th;
        *tOut = th;
        *uOut = s;
        *vOut = t;
        found = 1;
    }
    return found;
}

/* The nearest hit of the ray with the patch box in (tmin, tmax): t and the local (u, v). */
static inline int rc_intersect_patch_box(float3 o, float3 d, float tmin, float tmax,
                                         __global const float4* analytic,
                                         __global const RcPatchBox* box, float* tOut, float* uOut,
                                         float* vOut) {
    int outcome, steps, restartSteps;
    return rc_patch_box_newton(o, d, tmin, tmax, analytic, box, tOut, uOut, vOut, &outcome,
                               &steps, &restartSteps);
}

/* The surface point and its unnormalised normal at local (s, t) of a patch box. Where the
 * derivatives are parallel or vanish (a collapsed edge, like the teapot's lid and bottom, whose
 * edge rows meet in one point) the normal is taken a little inside, where it tends to the
 * limit normal. */
static inline float3 rc_patch_normal_at(__global const float4* pts, float s, float t,
                                        float3* point) {
    for (int attempt = 0; attempt < 3; ++attempt) {
        float bu[4], dbu[4], bv[4], dbv[4];
        rc_bernstein3(s, bu, dbu);
        rc_bernstein3(t, bv, dbv);
        float c[4][16];
        for (int k = 0; k < 16; ++k) {
            const float4 p = pts[k];
            c[0][k] = p.x;
            c[1][k] = p.y;
            c[2][k] = p.z;
            c[3][k] = p.w;
        }
        const float3 X = rc_patch_channel(c[0], bu, dbu, bv, dbv);
        const float3 Y = rc_patch_channel(c[1], bu, dbu, bv, dbv);
        const float3 Z = rc_patch_channel(c[2], bu, dbu, bv, dbv);
        const float3 W = rc_patch_channel(c[3], bu, dbu, bv, dbv);
        const float3 p = (float3)(X.x, Y.x, Z.x) / W.x;
        if (attempt == 0) *point = p;
        const float3 ds = (float3)(X.y, Y.y, Z.y) - p * W.y;
        const float3 dt = (float3)(X.z, Y.z, Z.z) - p * W.z;
        const float3 n = cross(ds, dt);
        if (dot(n, n) > 1e-10f * dot(ds, ds) * dot(dt, dt)) return n;
        s += (0.5f - s) * (attempt == 0 ? 0.001f : 0.01f);
        t += (0.5f - t) * (attempt == 0 ? 0.001f : 0.01f);
    }
    return (float3)(0.0f);
}
