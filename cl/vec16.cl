/* 3-vectors of 16 lanes (float16 over structure of arrays) and their arithmetic, lane by lane
 * the operations of the scalar float3 builtins (cross, dot) in the same order. */
#ifndef RC_VEC16_CL
#define RC_VEC16_CL

/* Forced inline: a call per vector operation would pass its float16s through memory. */
#define RC_V16_INLINE static __attribute__((always_inline)) inline

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

/* The least and the largest lane, and those of the lanes where `active`. */
RC_V16_INLINE float rc_hmin16(float16 a) {
    const float8 m8 = fmin(a.lo, a.hi);
    const float4 m4 = fmin(m8.lo, m8.hi);
    const float2 m2 = fmin(m4.lo, m4.hi);
    return fmin(m2.x, m2.y);
}
RC_V16_INLINE float rc_hmax16(float16 a) {
    const float8 m8 = fmax(a.lo, a.hi);
    const float4 m4 = fmax(m8.lo, m8.hi);
    const float2 m2 = fmax(m4.lo, m4.hi);
    return fmax(m2.x, m2.y);
}
RC_V16_INLINE float rc_active_min16(float16 a, int16 active) {
    return rc_hmin16(select((float16)(INFINITY), a, active));
}
RC_V16_INLINE float rc_active_max16(float16 a, int16 active) {
    return rc_hmax16(select((float16)(-INFINITY), a, active));
}

/* The least and the largest lane by selects, for values that are never NaN: rc_hmin16's fmin
 * checks every step for one. */
RC_V16_INLINE float rc_hmin16_ordered(float16 a) {
    const float8 m8 = select(a.hi, a.lo, a.lo < a.hi);
    const float4 m4 = select(m8.hi, m8.lo, m8.lo < m8.hi);
    const float2 m2 = select(m4.hi, m4.lo, m4.lo < m4.hi);
    return m2.x < m2.y ? m2.x : m2.y;
}
RC_V16_INLINE float rc_hmax16_ordered(float16 a) {
    const float8 m8 = select(a.hi, a.lo, a.lo > a.hi);
    const float4 m4 = select(m8.hi, m8.lo, m8.lo > m8.hi);
    const float2 m2 = select(m4.hi, m4.lo, m4.lo > m4.hi);
    return m2.x > m2.y ? m2.x : m2.y;
}

/* Clang's reductions of the lanes' signs compile to one mask test (vptest, kortest), where PoCL's
 * any() and all() test lane by lane or fold the signs with a chain of shuffles; other OpenCL
 * compilers take the portable forms. */
#if defined(__clang__) && defined(__has_builtin)
#if __has_builtin(__builtin_reduce_or) && __has_builtin(__builtin_reduce_and)
#define RC_HAVE_REDUCE_MASK
#endif
#endif

/* shuffle2(a, b, (uint16)(indices)) for constant indices. PoCL's shuffle2 builds its result
 * element by element, which LLVM turns back into a cascade of partial permutes and, where the
 * operands are loads, into loads of 8-byte pieces; Clang's builtin is one shuffle, which stays
 * one or two permute instructions of a float16 pair. */
#if defined(__clang__) && defined(__has_builtin)
#if __has_builtin(__builtin_shufflevector)
#define RC_SHUFFLE2(a, b, ...) __builtin_shufflevector(a, b, __VA_ARGS__)
#endif
#endif
#ifndef RC_SHUFFLE2
#define RC_SHUFFLE2(a, b, ...) shuffle2(a, b, (uint16)(__VA_ARGS__))
#endif

/* Whether any lane of the mask is set. */
RC_V16_INLINE int rc_any16(int16 m) {
#ifdef RC_HAVE_REDUCE_MASK
    return __builtin_reduce_or(m < 0) != 0;
#else
    const int8 m8 = m.lo | m.hi;
    const int4 m4 = m8.lo | m8.hi;
    const int2 m2 = m4.lo | m4.hi;
    return (m2.x | m2.y) < 0;
#endif
}

/* Whether every lane of the mask is set. */
RC_V16_INLINE int rc_all16(int16 m) {
#ifdef RC_HAVE_REDUCE_MASK
    return __builtin_reduce_and(m < 0) != 0;
#else
    return all(m);
#endif
}

/* How many lanes of the mask are set. */
RC_V16_INLINE int rc_count16(int16 mask) {
    const int16 ones = mask & 1;
    const int8 s8 = ones.lo + ones.hi;
    const int4 s4 = s8.lo + s8.hi;
    const int2 s2 = s4.lo + s4.hi;
    return s2.x + s2.y;
}

/* Field f of 16 float4s a[0..15] as the lanes of a float16: rays read as float4 and transposed
 * in registers. */
#define RC_LANES16(a, f)                                                                      \
    (float16)(a[0].f, a[1].f, a[2].f, a[3].f, a[4].f, a[5].f, a[6].f, a[7].f, a[8].f, a[9].f, \
              a[10].f, a[11].f, a[12].f, a[13].f, a[14].f, a[15].f)

#endif
