// AVX-512 helpers of the classify module (included only where __AVX512F__ is defined).
#pragma once

#include <immintrin.h>

#include <cstddef>

namespace rayclass::classify {

// GCC 12's _mm512_min_ps/_mm512_max_ps start from an undefined vector and trip
// -Wmaybe-uninitialized; the zero-masked forms compute the same with every lane live.
inline __m512 Min16(__m512 a, __m512 b) { return _mm512_maskz_min_ps(__mmask16(0xFFFF), a, b); }
inline __m512 Max16(__m512 a, __m512 b) { return _mm512_maskz_max_ps(__mmask16(0xFFFF), a, b); }

// The lanes of the 16 elements from i on that exist among n.
inline __mmask16 LiveLanes16(size_t n, size_t i) {
    const size_t rest = n - i;
    return rest >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << rest) - 1u);
}

// Through memory: GCC 12's _mm512_reduce_min_ps/_max_ps trip the same warning.
inline float ReduceMin(__m512 v) {
    alignas(64) float x[16];
    _mm512_store_ps(x, v);
    float m = x[0];
    for (int i = 1; i < 16; ++i) m = x[i] < m ? x[i] : m;
    return m;
}
inline float ReduceMax(__m512 v) {
    alignas(64) float x[16];
    _mm512_store_ps(x, v);
    float m = x[0];
    for (int i = 1; i < 16; ++i) m = x[i] > m ? x[i] : m;
    return m;
}

}  // namespace rayclass::classify
