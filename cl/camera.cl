/* Eye rays: one per pixel, the formula documented at RcCamera in rc_types.h. A launch writes the
 * rays of the camera window's pixels [first, first + n) so big images go through in batches;
 * they get no RcRayInfo (see there). */
#include "rc_types.h"
#include "encoding.cl"

#pragma OPENCL FP_CONTRACT OFF

static inline float3 rc_eye_direction(__constant const RcCamera* cam, uint x, uint y) {
    const float sx = (2.0f * ((float)x + 0.5f) / (float)cam->width - 1.0f) * cam->tanHalfFovX;
    const float sy = (1.0f - 2.0f * ((float)y + 0.5f) / (float)cam->height) * cam->tanHalfFovY;
    return normalize(cam->forward.xyz + sx * cam->right.xyz + sy * cam->up.xyz);
}

__kernel __attribute__((reqd_work_group_size(RC_LOCAL_SIZE, 1, 1))) void rc_generate_eye_rays(
    __constant const RcCamera* cam, uint first, uint n, __global RcRay* rays) {
    const uint i = get_global_id(0);
    if (i >= n) return;
    const uint pixel = first + i;
    const uint x = cam->windowX + pixel % cam->windowWidth,
               y = cam->windowY + pixel / cam->windowWidth;
    RcRay r;
    r.origin = (float4)(cam->position.xyz, 0.0f);
    r.direction = (float4)(rc_encode_direction(rc_eye_direction(cam, x, y)), INFINITY);
    rays[i] = r;
}
