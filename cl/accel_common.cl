/* What the kd-tree, grid and cone kernels share: a ray's inverse direction without infinities, the
 * slack by which they widen ray intervals so that float rounding never skips a cell a ray
 * touches, and a ray's interval inside a box. */
#include "rc_types.h"

#pragma OPENCL FP_CONTRACT OFF

/* 1 / d, with a zero component replaced by a huge finite value of its sign: a slab distance is
 * then never 0 * infinity (NaN). */
inline float3 rc_accel_inverse(float3 d) {
    const float3 inv = (float3)(1.0f) / d;
    return select(inv, copysign((float3)(1e30f), inv), isinf(inv));
}

/* How far a computed distance t along a ray may be from the true one, with room to spare:
 * widening an interval by it only ever visits more cells. */
inline float rc_accel_slack(float t, float slackAbs) { return 1e-5f * fabs(t) + slackAbs; }

/* Narrows [*t0, *t1] to the ray's interval inside [lo, hi], widened by the slack; 0 when it is
 * empty. */
inline int rc_accel_clip(float3 o, float3 inv, float3 lo, float3 hi, float slackAbs, float* t0,
                         float* t1) {
    const float3 a = (lo - o) * inv, b = (hi - o) * inv;
    const float3 near = fmin(a, b), far = fmax(a, b);
    const float tn = fmax(fmax(near.x, near.y), near.z);
    const float tf = fmin(fmin(far.x, far.y), far.z);
    *t0 = fmax(*t0, tn - rc_accel_slack(tn, slackAbs));
    *t1 = fmin(*t1, tf + rc_accel_slack(tf, slackAbs));
    return *t0 <= *t1;
}

/* Component `axis` (0, 1, 2) of v. */
inline float rc_accel_component(float3 v, uint axis) {
    return axis == 0 ? v.x : (axis == 1 ? v.y : v.z);
}
