/* 3-vectors of 16 lanes (float16 over structure of arrays) and their arithmetic, lane by lane
 * the operations of the scalar float3 builtins (cross, dot) in the same order. */
#ifndef RC_VEC16_CL
#define RC_VEC16_CL

/* Forced inline: a call per vector operation would pass its float16s through memory. */
#define RC_V16_INLINE __attribute__((always_inline)) inline

/* A 3-vector a lane. */
typedef struct RcVec16 {
    float16 x, y, z;
} RcVec16;

RC_V16_INLINE RcVec16 rc_v16(float16 x, float16 y, float16 z) {
    RcVec16 v;
    v.x = x, v.y = y, v.z = z;
    return v;
}
RC_V16_INLINE RcVec16 rc_v16_add(RcVec16 a, RcVec16 b) {
    return rc_v16(a.x + b.x, a.y + b.y, a.z + b.z);
}
RC_V16_INLINE RcVec16 rc_v16_sub(RcVec16 a, RcVec16 b) {
    return rc_v16(a.x - b.x, a.y - b.y, a.z - b.z);
}
RC_V16_INLINE RcVec16 rc_v16_scale(RcVec16 a, float16 s) {
    return rc_v16(a.x * s, a.y * s, a.z * s);
}
RC_V16_INLINE float16 rc_v16_dot(RcVec16 a, RcVec16 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
RC_V16_INLINE float16 rc_v16_length(RcVec16 a) { return sqrt(rc_v16_dot(a, a)); }
RC_V16_INLINE RcVec16 rc_v16_cross(RcVec16 a, RcVec16 b) {
    return rc_v16(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
/* b where `take`, else a. */
RC_V16_INLINE RcVec16 rc_v16_select(RcVec16 a, RcVec16 b, int16 take) {
    return rc_v16(select(a.x, b.x, take), select(a.y, b.y, take), select(a.z, b.z, take));
}
RC_V16_INLINE RcVec16 rc_v16_mul(RcVec16 a, RcVec16 b) {
    return rc_v16(a.x * b.x, a.y * b.y, a.z * b.z);
}
RC_V16_INLINE RcVec16 rc_v16_neg(RcVec16 a) { return rc_v16(-a.x, -a.y, -a.z); }
RC_V16_INLINE float16 rc_v16_max3(RcVec16 a) { return fmax(a.x, fmax(a.y, a.z)); }

#endif
