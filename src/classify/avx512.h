// The classify module's AVX-512 paths. They are compiled into every x86-64 build, each function
// with a target attribute, and chosen at run time where the CPU has the extensions (UseAvx512),
// so that one binary runs on any x86-64 CPU. Every AVX-512 path computes exactly what its
// generic twin computes.
#pragma once

#include <cstddef>

#if defined(__x86_64__)
#define RC_AVX512_PATHS 1
#include <immintrin.h>
#define RC_AVX512 __attribute__((target("avx512f,avx512cd,avx512bw,avx512dq,avx512vl,avx512vbmi2")))
#endif

namespace rayclass::classify {

// Whether the AVX-512 paths run: the CPU has AVX-512 F, CD, BW, DQ, VL and VBMI2, and the
// environment variable RAYCLASS_SIMD (rayclass/core/simd.h) does not ask for the
// generic paths. Throws when RAYCLASS_SIMD is not one of those, or asks for AVX-512 on a CPU
// without it.
bool UseAvx512();

#if defined(RC_AVX512_PATHS)
// GCC 12's _mm512_min_ps/_mm512_max_ps start from an undefined vector and trip
// -Wmaybe-uninitialized; the zero-masked forms compute the same with every lane live.
RC_AVX512 inline __m512 Min16(__m512 a, __m512 b) {
    return _mm512_maskz_min_ps(__mmask16(0xFFFF), a, b);
}
RC_AVX512 inline __m512 Max16(__m512 a, __m512 b) {
    return _mm512_maskz_max_ps(__mmask16(0xFFFF), a, b);
}

// The lanes of the 16 elements from i on that exist among n.
RC_AVX512 inline __mmask16 LiveLanes16(size_t n, size_t i) {
    const size_t rest = n - i;
    return rest >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << rest) - 1u);
}

// Through memory: GCC 12's _mm512_reduce_min_ps/_max_ps trip the same warning.
RC_AVX512 inline float ReduceMin(__m512 v) {
    alignas(64) float x[16];
    _mm512_store_ps(x, v);
    float m = x[0];
    for (int i = 1; i < 16; ++i) m = x[i] < m ? x[i] : m;
    return m;
}
RC_AVX512 inline float ReduceMax(__m512 v) {
    alignas(64) float x[16];
    _mm512_store_ps(x, v);
    float m = x[0];
    for (int i = 1; i < 16; ++i) m = x[i] > m ? x[i] : m;
    return m;
}
#endif

}  // namespace rayclass::classify
