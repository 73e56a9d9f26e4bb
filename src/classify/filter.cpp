#include "filter.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "avx512.h"

namespace rayclass::classify {

namespace {

constexpr float kTinySlope = 1e-30f;

float WidenUpper(float s) { return s == 0.0f ? kTinySlope : s; }
float WidenLower(float s) { return s == 0.0f ? -kTinySlope : s; }

// Steps are at most 65535, where a float's ulp is 2^-8: converting a world coordinate into steps
// errs by a few of those. The beam grows by this margin, so that rounding never narrows it.
constexpr float kStepMargin = 1.0f / 32.0f;

#if defined(RC_AVX512_PATHS)

// Whether a filter of `in` by `t` may skip the blocks whose box `t` cannot reach: `in` has a
// summary, and the test's values are finite and small enough that no difference or product in
// it overflows (no infinity or NaN), so each step of the test is monotone in the box's bounds
// and a block's box yields a range [lo, hi] that holds each of its entries' ranges.
bool SkipsBlocks(const BeamTest& t, const ListView& in) {
    if (in.blocks.x0 == nullptr) return false;
    constexpr float kCoordMax = 0x1p24f, kReciprocalMax = 0x1p100f;
    const bool coords = std::abs(t.x0) <= kCoordMax && std::abs(t.x1) <= kCoordMax &&
                        std::abs(t.y0) <= kCoordMax && std::abs(t.y1) <= kCoordMax &&
                        std::abs(t.z0) <= kCoordMax && std::abs(t.z1) <= kCoordMax &&
                        std::abs(t.reach) <= kCoordMax;
    const bool slopes = std::abs(t.ru1) <= kReciprocalMax && std::abs(t.ru0) <= kReciprocalMax &&
                        std::abs(t.rv1) <= kReciprocalMax && std::abs(t.rv0) <= kReciprocalMax;
    return coords && slopes;
}

// 16 boxes' coordinate in steps, as floats (maskz: see avx512.h).
RC_AVX512 inline __m512 Widen16(__m256i steps) {
    return _mm512_maskz_cvtepi32_ps(__mmask16(0xFFFF),
                                    _mm512_maskz_cvtepu16_epi32(__mmask16(0xFFFF), steps));
}

// A beam's test, broadcast to 16 lanes.
struct BeamLanes {
    __m512 x0, x1, y0, y1, z0, z1, ru1, ru0, rv1, rv0, reach;
};
RC_AVX512 inline BeamLanes Lanes(const BeamTest& t) {
    return {_mm512_set1_ps(t.x0),  _mm512_set1_ps(t.x1),   _mm512_set1_ps(t.y0),
            _mm512_set1_ps(t.y1),  _mm512_set1_ps(t.z0),   _mm512_set1_ps(t.z1),
            _mm512_set1_ps(t.ru1), _mm512_set1_ps(t.ru0),  _mm512_set1_ps(t.rv1),
            _mm512_set1_ps(t.rv0), _mm512_set1_ps(t.reach)};
}
// The live ones of 16 boxes (bounds b, widened) that the beam may reach (BeamMayReach).
template <int kSigns>
RC_AVX512 inline __mmask16 Keep16(const BeamLanes& t, const __m512 b[6], __mmask16 live) {
    __m512 lo = Max16(_mm512_sub_ps(b[0], t.x1), _mm512_setzero_ps());
    __m512 hi = Min16(_mm512_sub_ps(b[1], t.x0), t.reach);
    const __m512 c0 = _mm512_mul_ps(_mm512_sub_ps(b[2], t.y1), t.ru1);
    const __m512 c1 = _mm512_mul_ps(_mm512_sub_ps(b[3], t.y0), t.ru0);
    const __m512 e0 = _mm512_mul_ps(_mm512_sub_ps(b[4], t.z1), t.rv1);
    const __m512 e1 = _mm512_mul_ps(_mm512_sub_ps(b[5], t.z0), t.rv0);
    if constexpr (kSigns & 1)
        lo = Max16(lo, c0);
    else
        hi = Min16(hi, c0);
    if constexpr (kSigns & 2)
        hi = Min16(hi, c1);
    else
        lo = Max16(lo, c1);
    if constexpr (kSigns & 4)
        lo = Max16(lo, e0);
    else
        hi = Min16(hi, e0);
    if constexpr (kSigns & 8)
        hi = Min16(hi, e1);
    else
        lo = Max16(lo, e1);
    return _mm512_mask_cmp_ps_mask(live, lo, hi, _CMP_LE_OQ);
}
// The `keep` lanes of 16 entries (bounds q, primitives from `prim`) appended to out at k;
// returns the new k. Compresses in registers and stores with a mask: compress-to-memory is
// microcoded on Zen 4.
RC_AVX512 inline size_t Append16(const __m256i q[6], const uint32_t* prim, __mmask16 live,
                                 __mmask16 keep, const ListOut& out, size_t k) {
    if (!keep) return k;
    uint16_t* const dst[6] = {out.x0, out.x1, out.y0, out.y1, out.z0, out.z1};
    const __mmask16 kept = __mmask16((1u << std::popcount(unsigned(keep))) - 1u);
    for (int a = 0; a < 6; ++a)
        _mm256_mask_storeu_epi16(dst[a] + k, kept, _mm256_maskz_compress_epi16(keep, q[a]));
    const __m512i p = _mm512_maskz_loadu_epi32(live, prim);
    _mm512_mask_storeu_epi32(out.prim + k, kept, _mm512_maskz_compress_epi32(keep, p));
    return k + size_t(std::popcount(unsigned(keep)));
}
// Entries i .. i + 15 of `in` (the live ones): their bounds in steps, and widened to floats.
RC_AVX512 inline void Load16(const ListView& in, size_t i, __mmask16 live, __m256i q[6],
                             __m512 b[6]) {
    const uint16_t* const src[6] = {in.x0, in.x1, in.y0, in.y1, in.z0, in.z1};
    for (int a = 0; a < 6; ++a) {
        q[a] = _mm256_maskz_loadu_epi16(live, src[a] + i);
        b[a] = Widen16(q[a]);
    }
}
// The blocks of entries i .. i + 16 kListBlock - 1 of `in` (the live ones) whose box the beam
// may reach: bit j for the block of entries from i + 16 j on.
template <int kSigns>
RC_AVX512 inline unsigned ReachedBlocks16(const BeamLanes& t, const ListView& in, size_t i) {
    static_assert(kListBlock == 16);
    const ListBlocks& blocks = in.blocks;
    const uint16_t* const src[6] = {blocks.x0, blocks.x1, blocks.y0,
                                    blocks.y1, blocks.z0, blocks.z1};
    const size_t first = i / kListBlock;
    const __mmask16 live = LiveLanes16(BlockCount(in.n), first);
    __m512 b[6];
    for (int a = 0; a < 6; ++a) b[a] = Widen16(_mm256_maskz_loadu_epi16(live, src[a] + first));
    return Keep16<kSigns>(t, b, live);
}
// FilterAvx512's loop over the blocks of entries that `blocks` (ReachedBlocks16 of the block
// groups) says some beam may reach: `body(i)` filters entries i .. i + 15.
template <typename Blocks, typename Body>
RC_AVX512 inline void ForReachedBlocks(const ListView& in, Blocks&& blocks, Body&& body) {
    for (size_t i = 0; i < in.n; i += 16 * kListBlock) {
        for (unsigned m = blocks(i); m; m &= m - 1) body(i + size_t(std::countr_zero(m)) * 16);
    }
}
template <int kSigns>
RC_AVX512 size_t FilterAvx512(const BeamTest& t, const ListView& in, const ListOut& out) {
    const BeamLanes beam = Lanes(t);
    size_t k = 0;
    auto filter16 = [&](size_t i) RC_AVX512 {
        const __mmask16 live = LiveLanes16(in.n, i);
        __m256i q[6];
        __m512 b[6];
        Load16(in, i, live, q, b);
        k = Append16(q, in.prim + i, live, Keep16<kSigns>(beam, b, live), out, k);
    };
    if (SkipsBlocks(t, in)) {
        ForReachedBlocks(
            in, [&](size_t i) RC_AVX512 { return ReachedBlocks16<kSigns>(beam, in, i); }, filter16);
    } else {
        for (size_t i = 0; i < in.n; i += 16) filter16(i);
    }
    return k;
}
// FilterAvx512 for two beams of the same signs in one pass over the list.
template <int kSigns>
RC_AVX512 void FilterPairAvx512(const BeamTest t[2], const ListView& in, const ListOut out[2],
                                size_t kept[2]) {
    const BeamLanes beam[2] = {Lanes(t[0]), Lanes(t[1])};
    size_t k[2] = {0, 0};
    auto filter16 = [&](size_t i) RC_AVX512 {
        const __mmask16 live = LiveLanes16(in.n, i);
        __m256i q[6];
        __m512 b[6];
        Load16(in, i, live, q, b);
        for (int j = 0; j < 2; ++j)
            k[j] = Append16(q, in.prim + i, live, Keep16<kSigns>(beam[j], b, live), out[j], k[j]);
    };
    if (SkipsBlocks(t[0], in) && SkipsBlocks(t[1], in)) {
        ForReachedBlocks(
            in,
            [&](size_t i) RC_AVX512 {
                return ReachedBlocks16<kSigns>(beam[0], in, i) |
                       ReachedBlocks16<kSigns>(beam[1], in, i);
            },
            filter16);
    } else {
        for (size_t i = 0; i < in.n; i += 16) filter16(i);
    }
    kept[0] = k[0];
    kept[1] = k[1];
}
template <int kSigns = 0>
RC_AVX512 size_t Dispatch(const BeamTest& t, const ListView& in, const ListOut& out) {
    if constexpr (kSigns == 16) {
        return 0;
    } else {
        if (t.signs == kSigns) return FilterAvx512<kSigns>(t, in, out);
        return Dispatch<kSigns + 1>(t, in, out);
    }
}
template <int kSigns = 0>
RC_AVX512 void DispatchPair(const BeamTest t[2], const ListView& in, const ListOut out[2],
                            size_t kept[2]) {
    if constexpr (kSigns < 16) {
        if (t[0].signs == kSigns) return FilterPairAvx512<kSigns>(t, in, out, kept);
        DispatchPair<kSigns + 1>(t, in, out, kept);
    }
}

#endif

}  // namespace

ListFrame MakeListFrame(const float lo[3], const float hi[3]) {
    ListFrame frame;
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1] && lo[2] <= hi[2])) return frame;
    double extent = 0.0;
    for (int k = 0; k < 3; ++k) {
        frame.base[k] = lo[k];
        extent = std::max(extent, double(hi[k]) - double(lo[k]));
    }
    // The frame spans the boxes, and 65534 steps rounded up keep the highest bound below 65535
    // whatever the rounding: every bound maps into 16 bits.
    const float step = float(extent / 65534.0);
    frame.step = double(step) * 65534.0 >= extent
                     ? step
                     : std::nextafter(step, std::numeric_limits<float>::infinity());
    if (!(frame.step > 0.0f)) frame.step = 1.0f;  // every box a point: any step holds it
    // A box's near X, at most hi[0], rounds down to at most floor(ToSteps(hi[0])), which an end
    // at or beyond hi[0] reaches: its ToSteps is no less, and float rounding keeps integers.
    frame.keepsAll = hi[0];
    return frame;
}

namespace {
#if defined(RC_AVX512_PATHS)
// StepsBelow (kRound _MM_FROUND_TO_NEG_INF) or StepsAbove (_MM_FROUND_TO_POS_INF) of 16 world
// coordinates, in double as they compute it.
template <int kRound>
RC_AVX512 __m256i Steps16(__m512 c, __m512d base, __m512d step) {
    // (maskz forms throughout: GCC 12 warns of the plain forms' undefined pass-through)
    const __mmask8 all8 = 0xFF;
    const __m512d zero = _mm512_setzero_pd(), top = _mm512_set1_pd(65535.0);
    auto half = [&](__m256 x) RC_AVX512 {
        const __m512d s = _mm512_maskz_div_pd(
            all8, _mm512_maskz_sub_pd(all8, _mm512_maskz_cvtps_pd(all8, x), base), step);
        const __m512d r = _mm512_maskz_roundscale_pd(all8, s, kRound | _MM_FROUND_NO_EXC);
        return _mm512_maskz_cvttpd_epi32(
            all8, _mm512_maskz_min_pd(all8, _mm512_maskz_max_pd(all8, r, zero), top));
    };
    const __m512i both = _mm512_maskz_inserti64x4(
        all8, _mm512_castsi256_si512(half(_mm512_maskz_extractf32x8_ps(all8, c, 0))),
        half(_mm512_maskz_extractf32x8_ps(all8, c, 1)), 1);
    return _mm512_maskz_cvtepi32_epi16(__mmask16(0xFFFF), both);
}
#endif

#if defined(RC_AVX512_PATHS)
// FillFaceList's whole blocks of 16 boxes; returns the boxes done.
RC_AVX512 size_t FillFaceList16(int face, const ListFrame& frame, const Bounds3f* boxes,
                                const uint32_t* order, size_t n, const ListOut& out) {
    uint16_t* const dst[6] = {out.x0, out.x1, out.y0, out.y1, out.z0, out.z1};
    size_t i = 0;
    // Which of a box's six floats (lo x, y, z, hi x, y, z) BoxInFace puts at each bound of the
    // frame (lo X, hi X, lo Y, ...), and whether it negates it: read off a box whose floats
    // are 1 .. 6, so the mapping stays BoxInFace's own.
    const Box5 probe = BoxInFace(face, Bounds3f{{1.0f, 2.0f, 3.0f}, {4.0f, 5.0f, 6.0f}});
    int from[6];
    bool negate[6];
    for (int j = 0; j < 6; ++j) {
        const float v = j & 1 ? probe.hi[j / 2] : probe.lo[j / 2];
        from[j] = int(std::abs(v)) - 1;
        negate[j] = v < 0.0f;
    }
    const float* const base = reinterpret_cast<const float*>(boxes);
    __m512d frameBase[3];
    for (int k = 0; k < 3; ++k) frameBase[k] = _mm512_set1_pd(double(frame.base[k]));
    const __m512d step = _mm512_set1_pd(double(frame.step));
    const __m512 signMask = _mm512_castsi512_ps(_mm512_set1_epi32(int(0x80000000u)));
    for (; i + 16 <= n; i += 16) {
        const __m512i id = _mm512_loadu_si512(order + i);
        _mm512_storeu_si512(out.prim + i, id);
        const __m512i at = _mm512_mullo_epi32(id, _mm512_set1_epi32(6));
        for (int j = 0; j < 6; ++j) {
            __m512 v =
                _mm512_mask_i32gather_ps(_mm512_setzero_ps(), __mmask16(0xFFFF),
                                         _mm512_add_epi32(at, _mm512_set1_epi32(from[j])), base, 4);
            if (negate[j]) v = _mm512_xor_ps(v, signMask);
            const __m256i s = j & 1 ? Steps16<_MM_FROUND_TO_POS_INF>(v, frameBase[j / 2], step)
                                    : Steps16<_MM_FROUND_TO_NEG_INF>(v, frameBase[j / 2], step);
            _mm256_storeu_si256(reinterpret_cast<__m256i*>(dst[j] + i), s);
        }
    }
    return i;
}
#endif
}  // namespace

void FillFaceList(int face, const ListFrame& frame, const Bounds3f* boxes, const uint32_t* order,
                  size_t n, const ListOut& out) {
    static_assert(sizeof(Bounds3f) == 6 * sizeof(float));
    uint16_t* const dst[6] = {out.x0, out.x1, out.y0, out.y1, out.z0, out.z1};
    size_t i = 0;
#if defined(RC_AVX512_PATHS)
    if (UseAvx512()) i = FillFaceList16(face, frame, boxes, order, n, out);
#endif
    for (; i < n; ++i) {
        const Box5 box = BoxInFace(face, boxes[order[i]]);
        for (int k = 0; k < 3; ++k) {
            dst[2 * k][i] = StepsBelow(frame, k, box.lo[k]);
            dst[2 * k + 1][i] = StepsAbove(frame, k, box.hi[k]);
        }
        out.prim[i] = order[i];
    }
}

namespace {

#if defined(RC_AVX512_PATHS)
// The halves of each block's lanes when two vectors of 32 16-bit lanes, each of 32 / lanes blocks
// of `lanes` lanes, become one of twice the blocks of half the lanes, in order: `second` picks
// the upper half.
RC_AVX512 __m512i HalfLanes(int lanes, bool second) {
    alignas(64) uint16_t idx[32];
    const int blocks = 32 / lanes, half = lanes / 2;
    for (int o = 0; o < 32; ++o) {
        const int t = o / half, l = o % half;
        idx[o] = uint16_t((t < blocks ? 0 : 32) + (t % blocks) * lanes + l + (second ? half : 0));
    }
    return _mm512_load_si512(idx);
}

// The lanewise least (kMax: greatest) of 32 16-bit lanes.
template <bool kMax>
RC_AVX512 inline __m512i Pick32(__m512i a, __m512i b) {
    constexpr __mmask32 kAll32 = 0xFFFFFFFFu;
    return kMax ? _mm512_maskz_max_epu16(kAll32, a, b) : _mm512_maskz_min_epu16(kAll32, a, b);
}
// The least (kMax: greatest) of each block of 16 of `src`'s entries i .. i + 255 (those below n),
// the blocks' results in order, by halving the lanes of each block three times and then once
// within 32-bit lanes.
template <bool kMax>
RC_AVX512 __m256i Blocks16(const uint16_t* src, size_t n, size_t i, const __m512i halves[3][2]) {
    constexpr __mmask32 kAll32 = 0xFFFFFFFFu;
    const __m512i fill = _mm512_set1_epi16(kMax ? 0 : -1);
    __m512i v[8];
    for (size_t j = 0; j < 8; ++j) {
        const size_t at = i + 32 * j;
        const __mmask32 live = at >= n        ? __mmask32(0)
                               : n - at >= 32 ? kAll32
                                              : __mmask32((1u << (n - at)) - 1u);
        v[j] = _mm512_mask_loadu_epi16(fill, live, src + at);
    }
    for (int step = 0, count = 8; count > 1; ++step, count /= 2) {
        for (int j = 0; j < count / 2; ++j) {
            v[j] = Pick32<kMax>(_mm512_permutex2var_epi16(v[2 * j], halves[step][0], v[2 * j + 1]),
                                _mm512_permutex2var_epi16(v[2 * j], halves[step][1], v[2 * j + 1]));
        }
    }
    const __m512i both = Pick32<kMax>(v[0], _mm512_maskz_srli_epi32(__mmask16(0xFFFF), v[0], 16));
    return _mm512_maskz_cvtepi32_epi16(__mmask16(0xFFFF), both);
}

RC_AVX512 void FillBlocks16(const ListView& list, const ListOut& out) {
    __m512i halves[3][2];
    for (int step = 0; step < 3; ++step) {
        for (int s = 0; s < 2; ++s) halves[step][s] = HalfLanes(16 >> step, s == 1);
    }
    const size_t nBlocks = BlockCount(list.n);
    for (size_t i = 0; i < list.n; i += 16 * kListBlock) {
        const size_t b = i / kListBlock;
        const __mmask16 live = LiveLanes16(nBlocks, b);
        _mm256_mask_storeu_epi16(out.x0 + b, live, Blocks16<false>(list.x0, list.n, i, halves));
        _mm256_mask_storeu_epi16(out.x1 + b, live, Blocks16<true>(list.x1, list.n, i, halves));
        _mm256_mask_storeu_epi16(out.y0 + b, live, Blocks16<false>(list.y0, list.n, i, halves));
        _mm256_mask_storeu_epi16(out.y1 + b, live, Blocks16<true>(list.y1, list.n, i, halves));
        _mm256_mask_storeu_epi16(out.z0 + b, live, Blocks16<false>(list.z0, list.n, i, halves));
        _mm256_mask_storeu_epi16(out.z1 + b, live, Blocks16<true>(list.z1, list.n, i, halves));
    }
}
#endif

}  // namespace

void FillBlocks(const ListView& list, const ListOut& out) {
    static_assert(kListBlock == 16);
#if defined(RC_AVX512_PATHS)
    if (UseAvx512()) return FillBlocks16(list, out);
#endif
    const uint16_t* const lower[3] = {list.x0, list.y0, list.z0};
    const uint16_t* const upper[3] = {list.x1, list.y1, list.z1};
    uint16_t* const lo[3] = {out.x0, out.y0, out.z0};
    uint16_t* const hi[3] = {out.x1, out.y1, out.z1};
    for (size_t b = 0; b < BlockCount(list.n); ++b) {
        const size_t first = b * kListBlock, last = std::min(list.n, first + kListBlock);
        for (int k = 0; k < 3; ++k) {
            lo[k][b] = *std::min_element(lower[k] + first, lower[k] + last);
            hi[k][b] = *std::max_element(upper[k] + first, upper[k] + last);
        }
    }
}

bool FilterSkipsBlocks() {
#if defined(RC_AVX512_PATHS)
    return UseAvx512();
#else
    return false;
#endif
}

namespace {

#if defined(RC_AVX512_PATHS)
// WriteCandidates' whole blocks of 16 entries; returns the entries done. The fused multiply-add
// rounds once, as WorldBelow's std::fma does.
RC_AVX512 size_t WriteCandidates16(const ListView& list, size_t n, RcCandidate* out) {
    const __mmask16 all = 0xFFFF;
    const __m512 step = _mm512_set1_ps(list.frame->step);
    const __m512 base = _mm512_set1_ps(list.frame->base[0]);
    // (prim, nearX) pairs of lanes 0-7 and of lanes 8-15.
    const __m512i pairsLo =
        _mm512_setr_epi32(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23);
    const __m512i pairsHi = _mm512_add_epi32(pairsLo, _mm512_set1_epi32(8));
    size_t i = 0;
    for (; i + 16 <= n; i += 16) {
        const __m256i steps = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(list.x0 + i));
        const __m512 x = _mm512_maskz_fmadd_ps(
            all, _mm512_maskz_cvtepi32_ps(all, _mm512_maskz_cvtepu16_epi32(all, steps)), step,
            base);
        const __m512i prim = _mm512_loadu_si512(list.prim + i);
        const __m512i xi = _mm512_castps_si512(x);
        _mm512_storeu_si512(out + i, _mm512_maskz_permutex2var_epi32(all, prim, pairsLo, xi));
        _mm512_storeu_si512(out + i + 8, _mm512_maskz_permutex2var_epi32(all, prim, pairsHi, xi));
    }
    return i;
}
#endif

}  // namespace

void WriteCandidates(const ListView& list, size_t n, RcCandidate* out) {
    size_t i = 0;
#if defined(RC_AVX512_PATHS)
    if (UseAvx512()) i = WriteCandidates16(list, n, out);
#endif
    for (; i < n; ++i) out[i] = {list.prim[i], WorldBelow(*list.frame, 0, list.x0[i])};
}

size_t CountUpTo(const ListView& list, float endHi) {
    // Beams that run to the scene box's far side (eye rays' always) keep the whole list: no
    // search through it, whose first probes miss the cache on a long list, and no division.
    if (list.n == 0 || endHi >= list.frame->keepsAll) return list.n;
    const float limit = float(ToSteps(*list.frame, 0, endHi)) + kStepMargin;
    if (float(list.x0[list.n - 1]) <= limit) return list.n;
    return size_t(std::upper_bound(list.x0, list.x0 + list.n, limit,
                                   [](float v, uint16_t q) { return v < float(q); }) -
                  list.x0);
}

namespace {

constexpr size_t kSampledFilterMin = 4096;  // lists shorter than this are always filtered
constexpr float kSkipKeep = 0.8f;           // skip the filter when it would keep more
constexpr size_t kSamples = 64;             // boxes tested for the estimate

// The fraction of kSamples evenly spaced boxes of the list (cut at the end) that the beam keeps.
float SampledKeepFraction(const Bounds6& tight, const ListView& list) {
    const ListView in = CutAtEnd(tight, list);
    if (in.n < kSampledFilterMin) return 0.0f;
    const BeamTest t = MakeBeamTest(*in.frame, tight.ToBox5(), tight.hi[kDims] - tight.lo[0]);
    size_t kept = 0, tested = 0;
    const size_t stride = in.n / kSamples;
    for (size_t i = stride / 2; i < in.n; i += stride) {
        kept += BeamMayReach(t, in.x0[i], in.x1[i], in.y0[i], in.y1[i], in.z0[i], in.z1[i]) ? 1 : 0;
        ++tested;
    }
    return float(kept) / float(tested);
}

}  // namespace

ListView CutAtEnd(const Bounds6& tight, const ListView& list) {
    ListView in = list;
    in.n = CountUpTo(list, tight.hi[kDims]);
    return in;
}

bool KeepsMost(const Bounds6& tight, const ListView& list) {
    return list.n >= kSampledFilterMin && SampledKeepFraction(tight, list) > kSkipKeep;
}

BeamTest MakeBeamTest(const ListFrame& frame, const Box5& box, float reach) {
    // One division, not seven (a classification makes a test per node): the product errs by an
    // ulp of a double, far inside the margin.
    const double perStep = 1.0 / double(frame.step);
    auto steps = [&](int axis, float c) {
        return (double(c) - double(frame.base[axis])) * perStep;
    };
    auto below = [&](int axis) { return float(steps(axis, box.lo[axis])) - kStepMargin; };
    auto above = [&](int axis) { return float(steps(axis, box.hi[axis])) + kStepMargin; };
    BeamTest t;
    t.x0 = below(0);
    t.x1 = above(0);
    t.y0 = below(1);
    t.y1 = above(1);
    t.z0 = below(2);
    t.z1 = above(2);
    const float u1 = WidenUpper(box.hi[3]);
    const float u0 = WidenLower(box.lo[3]);
    const float v1 = WidenUpper(box.hi[4]);
    const float v0 = WidenLower(box.lo[4]);
    t.ru1 = 1.0f / u1;
    t.ru0 = 1.0f / u0;
    t.rv1 = 1.0f / v1;
    t.rv0 = 1.0f / v0;
    t.reach = float(double(reach) * perStep) + kStepMargin;
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
#if defined(RC_AVX512_PATHS)
    if (UseAvx512()) return Dispatch(t, in, out);
#endif
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
}

void FilterPair(const BeamTest t[2], const ListView& in, const ListOut out[2], size_t kept[2]) {
#if defined(RC_AVX512_PATHS)
    if (UseAvx512() && t[0].signs == t[1].signs) return DispatchPair(t, in, out, kept);
#endif
    for (int j = 0; j < 2; ++j) kept[j] = FilterList(t[j], in, out[j]);
}

}  // namespace rayclass::classify
