#include "filter.h"

#include <algorithm>
#include <bit>

#if defined(__AVX512F__)
#include "avx512.h"
#endif

namespace rayclass::classify {

namespace {

constexpr float kTinySlope = 1e-30f;

float WidenUpper(float s) { return s == 0.0f ? kTinySlope : s; }
float WidenLower(float s) { return s == 0.0f ? -kTinySlope : s; }

#if defined(__AVX512F__)

template <int kSigns>
size_t FilterAvx512(const BeamTest& t, const ListView& in, const ListOut& out) {
    const __m512 x0 = _mm512_set1_ps(t.x0), x1 = _mm512_set1_ps(t.x1);
    const __m512 y0 = _mm512_set1_ps(t.y0), y1 = _mm512_set1_ps(t.y1);
    const __m512 z0 = _mm512_set1_ps(t.z0), z1 = _mm512_set1_ps(t.z1);
    const __m512 ru1 = _mm512_set1_ps(t.ru1), ru0 = _mm512_set1_ps(t.ru0);
    const __m512 rv1 = _mm512_set1_ps(t.rv1), rv0 = _mm512_set1_ps(t.rv0);
    const __m512 reach = _mm512_set1_ps(t.reach);
    const __m512 zero = _mm512_setzero_ps();
    float* ox0 = out.x0;
    float* ox1 = out.x1;
    float* oy0 = out.y0;
    float* oy1 = out.y1;
    float* oz0 = out.z0;
    float* oz1 = out.z1;
    uint32_t* oprim = out.prim;
    size_t k = 0;
    for (size_t i = 0; i < in.n; i += 16) {
        const size_t rest = in.n - i;
        const __mmask16 live = rest >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << rest) - 1u);
        const __m512 bx0 = _mm512_maskz_loadu_ps(live, in.x0 + i);
        const __m512 bx1 = _mm512_maskz_loadu_ps(live, in.x1 + i);
        const __m512 by0 = _mm512_maskz_loadu_ps(live, in.y0 + i);
        const __m512 by1 = _mm512_maskz_loadu_ps(live, in.y1 + i);
        const __m512 bz0 = _mm512_maskz_loadu_ps(live, in.z0 + i);
        const __m512 bz1 = _mm512_maskz_loadu_ps(live, in.z1 + i);
        __m512 lo = Max16(_mm512_sub_ps(bx0, x1), zero);
        __m512 hi = Min16(_mm512_sub_ps(bx1, x0), reach);
        const __m512 c0 = _mm512_mul_ps(_mm512_sub_ps(by0, y1), ru1);
        const __m512 c1 = _mm512_mul_ps(_mm512_sub_ps(by1, y0), ru0);
        const __m512 e0 = _mm512_mul_ps(_mm512_sub_ps(bz0, z1), rv1);
        const __m512 e1 = _mm512_mul_ps(_mm512_sub_ps(bz1, z0), rv0);
        if constexpr (kSigns & 1) lo = Max16(lo, c0); else hi = Min16(hi, c0);
        if constexpr (kSigns & 2) hi = Min16(hi, c1); else lo = Max16(lo, c1);
        if constexpr (kSigns & 4) lo = Max16(lo, e0); else hi = Min16(hi, e0);
        if constexpr (kSigns & 8) hi = Min16(hi, e1); else lo = Max16(lo, e1);
        const __mmask16 keep = _mm512_mask_cmp_ps_mask(live, lo, hi, _CMP_LE_OQ);
        if (!keep) continue;
        // Compress in registers and store with a mask: compress-to-memory is microcoded on Zen 4.
        const __mmask16 dst = __mmask16((1u << std::popcount(unsigned(keep))) - 1u);
        _mm512_mask_storeu_ps(ox0 + k, dst, _mm512_maskz_compress_ps(keep, bx0));
        _mm512_mask_storeu_ps(ox1 + k, dst, _mm512_maskz_compress_ps(keep, bx1));
        _mm512_mask_storeu_ps(oy0 + k, dst, _mm512_maskz_compress_ps(keep, by0));
        _mm512_mask_storeu_ps(oy1 + k, dst, _mm512_maskz_compress_ps(keep, by1));
        _mm512_mask_storeu_ps(oz0 + k, dst, _mm512_maskz_compress_ps(keep, bz0));
        _mm512_mask_storeu_ps(oz1 + k, dst, _mm512_maskz_compress_ps(keep, bz1));
        const __m512i p = _mm512_maskz_loadu_epi32(live, in.prim + i);
        _mm512_mask_storeu_epi32(oprim + k, dst, _mm512_maskz_compress_epi32(keep, p));
        k += size_t(std::popcount(unsigned(keep)));
    }
    return k;
}

template <int kSigns = 0>
size_t Dispatch(const BeamTest& t, const ListView& in, const ListOut& out) {
    if constexpr (kSigns == 16) {
        return 0;
    } else {
        if (t.signs == kSigns) return FilterAvx512<kSigns>(t, in, out);
        return Dispatch<kSigns + 1>(t, in, out);
    }
}

#endif

}  // namespace

BeamTest MakeBeamTest(const Box5& box, float reach) {
    BeamTest t;
    t.x0 = box.lo[0];
    t.x1 = box.hi[0];
    t.y0 = box.lo[1];
    t.y1 = box.hi[1];
    t.z0 = box.lo[2];
    t.z1 = box.hi[2];
    const float u1 = WidenUpper(box.hi[3]);
    const float u0 = WidenLower(box.lo[3]);
    const float v1 = WidenUpper(box.hi[4]);
    const float v0 = WidenLower(box.lo[4]);
    t.ru1 = 1.0f / u1;
    t.ru0 = 1.0f / u0;
    t.rv1 = 1.0f / v1;
    t.rv0 = 1.0f / v0;
    t.reach = reach;
    t.signs = (u1 > 0.0f ? 1 : 0) | (u0 > 0.0f ? 2 : 0) | (v1 > 0.0f ? 4 : 0) | (v0 > 0.0f ? 8 : 0);
    return t;
}

bool BeamMayReach(const BeamTest& t, float bx0, float bx1, float by0, float by1, float bz0,
                  float bz1) {
    float lo = std::max(bx0 - t.x1, 0.0f);
    float hi = std::min(bx1 - t.x0, t.reach);
    const float c0 = (by0 - t.y1) * t.ru1;
    const float c1 = (by1 - t.y0) * t.ru0;
    const float e0 = (bz0 - t.z1) * t.rv1;
    const float e1 = (bz1 - t.z0) * t.rv0;
    if (t.signs & 1) lo = std::max(lo, c0); else hi = std::min(hi, c0);
    if (t.signs & 2) hi = std::min(hi, c1); else lo = std::max(lo, c1);
    if (t.signs & 4) lo = std::max(lo, e0); else hi = std::min(hi, e0);
    if (t.signs & 8) hi = std::min(hi, e1); else lo = std::max(lo, e1);
    return lo <= hi;
}

size_t FilterList(const BeamTest& t, const ListView& in, const ListOut& out) {
#if defined(__AVX512F__)
    return Dispatch(t, in, out);
#else
    size_t k = 0;
    for (size_t i = 0; i < in.n; ++i) {
        out.x0[k] = in.x0[i];
        out.x1[k] = in.x1[i];
        out.y0[k] = in.y0[i];
        out.y1[k] = in.y1[i];
        out.z0[k] = in.z0[i];
        out.z1[k] = in.z1[i];
        out.prim[k] = in.prim[i];
        k += BeamMayReach(t, in.x0[i], in.x1[i], in.y0[i], in.y1[i], in.z0[i], in.z1[i]) ? 1 : 0;
    }
    return k;
#endif
}

}  // namespace rayclass::classify
