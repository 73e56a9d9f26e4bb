/* The thesis's compact ray direction (3.5.2.2, Fig. 23/24): polar angles (phi, theta) packed as
 * two 16-bit fixed-point values in one 32-bit word. phi = atan2(y, x) in [-pi, pi] and
 * theta = atan2(|(x, y)|, z) in [0, pi] (not acos(z): near the poles z rounds to 1 and acos loses
 * theta), each rounded to one of 65536 steps. The angular error is at most half a theta step
 * (pi / 131070) and half a phi step times sin(theta) (pi / 65535) in quadrature:
 * sqrt(1.25) pi / 65535 = 5.36e-5 rad, plus float rounding; poles included (there phi is
 * arbitrary but sin(theta) vanishes).
 *
 * With -DRC_POLAR16 the kernels that write rays (eye rays, reflection, refraction) round their
 * directions through this encoding, so a render shows what the encoding costs in accuracy. */
#include "rc_types.h"

#define RC_PI_F 3.14159265358979323846f

static inline uint rc_polar16_encode(float3 d) {
    const float phi = atan2(d.y, d.x);
    const float theta = atan2(sqrt(d.x * d.x + d.y * d.y), d.z);
    const uint p = (uint)rint((phi + RC_PI_F) * (65535.0f / (2.0f * RC_PI_F)));
    const uint t = (uint)rint(theta * (65535.0f / RC_PI_F));
    return (min(p, 65535u) << 16) | min(t, 65535u);
}

static inline float3 rc_polar16_decode(uint packed) {
    const float phi = (float)(packed >> 16) * (2.0f * RC_PI_F / 65535.0f) - RC_PI_F;
    const float theta = (float)(packed & 0xFFFFu) * (RC_PI_F / 65535.0f);
    const float s = sin(theta);
    return (float3)(s * cos(phi), s * sin(phi), cos(theta));
}

/* The direction a ray actually carries. */
static inline float3 rc_encode_direction(float3 d) {
#ifdef RC_POLAR16
    return rc_polar16_decode(rc_polar16_encode(d));
#else
    return d;
#endif
}

/* For tests and benchmarks: out[i] = decode(encode(in[i])). */
__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_polar16_roundtrip(
    __global const float4* in, uint n, __global float4* out) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    out[i] = (float4)(rc_polar16_decode(rc_polar16_encode(in[i].xyz)), 0.0f);
}
