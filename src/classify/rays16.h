// Sixteen rays at a time in AVX-512 registers: loading them from a RayView, taking them from
// their common ends and finding their faces, with the float operations of the scalar paths
// (ToRay5, CommonEnds::Oriented), so that both map a ray alike. Private to the classify module;
// its functions run only where UseAvx512() (avx512.h).
#pragma once

#include <algorithm>
#include <cstddef>

#include "avx512.h"
#include "rayclass/classify/ray5d.h"
#include "support.h"

#if defined(RC_AVX512_PATHS)

namespace rayclass::classify {

// Gather offsets (in floats) of 16 consecutive rays of `rays` from the first.
RC_AVX512 inline __m512i RayOffsets16(const RayView& rays) {
    return _mm512_mullo_epi32(
        _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15),
        _mm512_set1_epi32(int(rays.Stride() / 4)));
}

// DominantAxis of 16 directions (ties to the lower axis): a mask per axis, the direction's
// absolute components, |d_a| and whether d_a < 0.
struct Axis16 {
    __mmask16 isX, isY, isZ, neg;
    __m512 ax, ay, az, da;
};

RC_AVX512 inline Axis16 DominantAxis16(__m512 dx, __m512 dy, __m512 dz) {
    const __m512 absMask = _mm512_castsi512_ps(_mm512_set1_epi32(0x7FFFFFFF));
    Axis16 a;
    a.ax = _mm512_and_ps(dx, absMask);
    a.ay = _mm512_and_ps(dy, absMask);
    a.az = _mm512_and_ps(dz, absMask);
    a.isX = _mm512_cmp_ps_mask(a.ax, a.ay, _CMP_GE_OQ) & _mm512_cmp_ps_mask(a.ax, a.az, _CMP_GE_OQ);
    a.isY = __mmask16(~a.isX & _mm512_cmp_ps_mask(a.ay, a.az, _CMP_GE_OQ));
    a.isZ = __mmask16(~a.isX & ~a.isY);
    a.da = _mm512_mask_blend_ps(a.isX, _mm512_mask_blend_ps(a.isY, a.az, a.ay), a.ax);
    const __m512 sd = _mm512_mask_blend_ps(a.isX, _mm512_mask_blend_ps(a.isY, dz, dy), dx);
    a.neg = _mm512_cmp_ps_mask(sd, _mm512_setzero_ps(), _CMP_LT_OQ);
    return a;
}

// The lanes whose point (x, y, z) lies in the box [blo, bhi], bounds included.
RC_AVX512 inline __mmask16 InBox16(__m512 x, __m512 y, __m512 z, const __m512 blo[3],
                                   const __m512 bhi[3]) {
    return _mm512_cmp_ps_mask(x, blo[0], _CMP_GE_OQ) & _mm512_cmp_ps_mask(x, bhi[0], _CMP_LE_OQ) &
           _mm512_cmp_ps_mask(y, blo[1], _CMP_GE_OQ) & _mm512_cmp_ps_mask(y, bhi[1], _CMP_LE_OQ) &
           _mm512_cmp_ps_mask(z, blo[2], _CMP_GE_OQ) & _mm512_cmp_ps_mask(z, bhi[2], _CMP_LE_OQ);
}

// The lanes whose direction ToRay5's fast path maps: d_a > 0 and a finite sum of components (not
// finite when a component is NaN or infinite).
RC_AVX512 inline __mmask16 Mappable16(const Axis16& a, __m512 dx, __m512 dy, __m512 dz) {
    const __m512 absMask = _mm512_castsi512_ps(_mm512_set1_epi32(0x7FFFFFFF));
    const __m512 dsum = _mm512_add_ps(_mm512_add_ps(dx, dy), dz);
    return _mm512_cmp_ps_mask(a.da, _mm512_setzero_ps(), _CMP_GT_OQ) &
           _mm512_cmp_ps_mask(_mm512_and_ps(dsum, absMask), _mm512_set1_ps(kFloatMax), _CMP_LE_OQ);
}

// 16 rays mapped into their faces' frames: ToRay5's point and end X (its start's X plus its reach,
// cut where the face's X leaves the box).
struct Point16 {
    __m512 x, y, z, u, v, end;
};

// The point of rays that start at `start` (the box's corners blo, bhi) with directions d and
// segments [segLo, segHi], in the frame of their dominant axis `a`, for the lanes in `fast` (the
// others divide by one): ToRay5's fast path, operation for operation. Frame: X = s p_a, Y = p_b,
// Z = p_c with b = a + 1, c = a + 2 (mod 3).
RC_AVX512 inline Point16 FacePoint16(const __m512 start[3], __m512 dx, __m512 dy, __m512 dz,
                                     __m512 segLo, __m512 segHi, const Axis16& a, __mmask16 fast,
                                     const __m512 blo[3], const __m512 bhi[3]) {
    const __m512 signMask = _mm512_castsi512_ps(_mm512_set1_epi32(int(0x80000000u)));
    const __m512 one = _mm512_set1_ps(1.0f);
    const __m512 qx = start[0], qy = start[1], qz = start[2];
    Point16 p;
    const __m512 pa = _mm512_mask_blend_ps(a.isX, _mm512_mask_blend_ps(a.isY, qz, qy), qx);
    p.x = _mm512_mask_xor_ps(pa, a.neg, pa, signMask);
    p.y = _mm512_mask_blend_ps(a.isX, _mm512_mask_blend_ps(a.isY, qx, qz), qy);
    p.z = _mm512_mask_blend_ps(a.isX, _mm512_mask_blend_ps(a.isY, qy, qx), qz);
    const __m512 db = _mm512_mask_blend_ps(a.isX, _mm512_mask_blend_ps(a.isY, dx, dz), dy);
    const __m512 dc = _mm512_mask_blend_ps(a.isX, _mm512_mask_blend_ps(a.isY, dy, dx), dz);
    const __m512 inv = _mm512_div_ps(one, _mm512_mask_blend_ps(fast, one, a.da));
    p.u = _mm512_mul_ps(db, inv);
    p.v = _mm512_mul_ps(dc, inv);
    // Not finite (or beyond the largest float) becomes the largest float, as in both scalar
    // paths.
    const __m512 reach =
        Min16(_mm512_mul_ps(_mm512_sub_ps(segHi, segLo), a.da), _mm512_set1_ps(kFloatMax));
    const __m512 hiA =
        _mm512_mask_blend_ps(a.isX, _mm512_mask_blend_ps(a.isY, bhi[2], bhi[1]), bhi[0]);
    const __m512 loA =
        _mm512_mask_blend_ps(a.isX, _mm512_mask_blend_ps(a.isY, blo[2], blo[1]), blo[0]);
    const __m512 xEnd = _mm512_mask_xor_ps(hiA, a.neg, loA, signMask);  // BoxInFace's hi X
    p.end = Min16(_mm512_add_ps(p.x, reach), xEnd);
    return p;
}

// 16 rays' fields, gathered from a RayView.
struct Rays16 {
    __m512 ox, oy, oz, tmin, dx, dy, dz, tmax;
};

RC_AVX512 inline Rays16 Gather16(const float* at, __m512i idx, __mmask16 live) {
    const __m512 zero = _mm512_setzero_ps();
    Rays16 r;
    r.ox = _mm512_mask_i32gather_ps(zero, live, idx, at + 0, 4);
    r.oy = _mm512_mask_i32gather_ps(zero, live, idx, at + 1, 4);
    r.oz = _mm512_mask_i32gather_ps(zero, live, idx, at + 2, 4);
    r.tmin = _mm512_mask_i32gather_ps(zero, live, idx, at + 3, 4);
    r.dx = _mm512_mask_i32gather_ps(zero, live, idx, at + 4, 4);
    r.dy = _mm512_mask_i32gather_ps(zero, live, idx, at + 5, 4);
    r.dz = _mm512_mask_i32gather_ps(zero, live, idx, at + 6, 4);
    r.tmax = _mm512_mask_i32gather_ps(zero, live, idx, at + 7, 4);
    return r;
}

// The same for `live` consecutive rays of 32 bytes each (classify::Ray, RcRay): plain loads of two
// rays a vector, whose 128-bit quarters (four fields of a ray) one shuffle of whole quarters
// a register puts in the order rays k, k + 4, k + 8, k + 12; then a 4 x 4 transpose within each
// quarter, of shuffles that stay in their 128-bit lanes, instead of eight gathers.
RC_AVX512 inline Rays16 Load16Packed(const float* at, size_t live) {
    // (The zero-masked forms: see Min16.)
    constexpr __mmask16 kAll = 0xFFFF;
    auto ray = [&](size_t k) RC_AVX512 {
        return k < live ? _mm256_loadu_ps(at + 8 * k) : _mm256_setzero_ps();
    };
    __m512 lo[4], hi[4];  // ox, oy, oz, tmin and dx, dy, dz, tmax of rays k, k + 4, k + 8, k + 12
    for (size_t k = 0; k < 4; ++k) {
        const __m512 near = _mm512_insertf32x8(_mm512_castps256_ps512(ray(k)), ray(k + 4), 1);
        const __m512 far = _mm512_insertf32x8(_mm512_castps256_ps512(ray(k + 8)), ray(k + 12), 1);
        lo[k] = _mm512_maskz_shuffle_f32x4(kAll, near, far, _MM_SHUFFLE(2, 0, 2, 0));
        hi[k] = _mm512_maskz_shuffle_f32x4(kAll, near, far, _MM_SHUFFLE(3, 1, 3, 1));
    }
    // Within each quarter: fields 0 and 1 of rays 0-1 and 2-3, then fields 2 and 3.
    auto transpose = [](const __m512(&q)[4], __m512& f0, __m512& f1, __m512& f2,
                        __m512& f3) RC_AVX512 {
        constexpr __mmask16 kAll16 = 0xFFFF;
        constexpr __mmask8 kAll8 = 0xFF;
        const __m512d t0 = _mm512_castps_pd(_mm512_maskz_unpacklo_ps(kAll16, q[0], q[1]));
        const __m512d t1 = _mm512_castps_pd(_mm512_maskz_unpacklo_ps(kAll16, q[2], q[3]));
        const __m512d t2 = _mm512_castps_pd(_mm512_maskz_unpackhi_ps(kAll16, q[0], q[1]));
        const __m512d t3 = _mm512_castps_pd(_mm512_maskz_unpackhi_ps(kAll16, q[2], q[3]));
        f0 = _mm512_castpd_ps(_mm512_maskz_unpacklo_pd(kAll8, t0, t1));
        f1 = _mm512_castpd_ps(_mm512_maskz_unpackhi_pd(kAll8, t0, t1));
        f2 = _mm512_castpd_ps(_mm512_maskz_unpacklo_pd(kAll8, t2, t3));
        f3 = _mm512_castpd_ps(_mm512_maskz_unpackhi_pd(kAll8, t2, t3));
    };
    Rays16 r;
    transpose(lo, r.ox, r.oy, r.oz, r.tmin);
    transpose(hi, r.dx, r.dy, r.dz, r.tmax);
    return r;
}

// A pass that reads `rays` once, in order, 16 at a time: consecutive rays of 32 bytes are loaded
// whole (Load16Packed) and prefetched kAhead rays ahead, since with little work a ray the
// hardware's prefetch alone leaves the loads waiting; rays of another stride are gathered.
class RayStream16 {
  public:
    RC_AVX512 explicit RayStream16(const RayView& rays)
        : rays_(rays), idx_(RayOffsets16(rays)), packed_(rays.Stride() == 8 * sizeof(float)) {}

    // Rays [i, i + 16) of rays.size() (lanes `live`: LiveLanes16).
    RC_AVX512 Rays16 Load(size_t i, __mmask16 live) const {
        const size_t n = rays_.size();
        if (!packed_) return Gather16(rays_.Floats(i), idx_, live);
        if (i + kAhead + 16 <= n) Prefetch(rays_.Floats(i + kAhead));
        return Load16Packed(rays_.Floats(i), std::min<size_t>(16, n - i));
    }

  private:
    static constexpr size_t kAhead = 64;

    // The eight cache lines of 16 consecutive rays of 32 bytes.
    RC_AVX512 static void Prefetch(const float* at) {
        const char* bytes = reinterpret_cast<const char*>(at);
        for (int line = 0; line < 8; ++line) _mm_prefetch(bytes + 64 * line, _MM_HINT_T0);
    }

    RayView rays_;
    __m512i idx_;
    bool packed_;
};

// CommonEnds::Oriented for the live lanes of r, with the same float operations, so both paths
// take a ray alike. Returns the lanes taken from an end; `which`, when given, gets each such
// lane's end (CommonEnds::Match).
RC_AVX512 inline __mmask16 Orient16(const CommonEnds& ends, __mmask16 live, Rays16& r,
                                    __m512i* which = nullptr) {
    if (ends.n == 0) return 0;
    const __m512 zero = _mm512_setzero_ps();
    const __m512 absMask = _mm512_castsi512_ps(_mm512_set1_epi32(0x7FFFFFFF));
    const __m512 signMask = _mm512_castsi512_ps(_mm512_set1_epi32(int(0x80000000u)));
    const __m512 tol = _mm512_set1_ps(ends.tolerance);
    const __mmask16 noDir = _mm512_cmp_ps_mask(r.dx, zero, _CMP_EQ_OQ) &
                            _mm512_cmp_ps_mask(r.dy, zero, _CMP_EQ_OQ) &
                            _mm512_cmp_ps_mask(r.dz, zero, _CMP_EQ_OQ);
    const __mmask16 segment = __mmask16(
        live & ~noDir & _mm512_cmp_ps_mask(r.tmin, r.tmax, _CMP_LT_OQ) &
        _mm512_cmp_ps_mask(_mm512_and_ps(r.tmax, absMask), _mm512_set1_ps(kFloatMax), _CMP_LE_OQ));
    if (!segment) return 0;
    const __m512 ex = _mm512_add_ps(r.ox, _mm512_mul_ps(r.tmax, r.dx));
    const __m512 ey = _mm512_add_ps(r.oy, _mm512_mul_ps(r.tmax, r.dy));
    const __m512 ez = _mm512_add_ps(r.oz, _mm512_mul_ps(r.tmax, r.dz));
    auto near = [&](__m512 e, float p) RC_AVX512 {
        return _mm512_cmp_ps_mask(_mm512_and_ps(_mm512_sub_ps(e, _mm512_set1_ps(p)), absMask), tol,
                                  _CMP_LE_OQ);
    };
    __mmask16 matched = 0;
    __m512 px = zero, py = zero, pz = zero;
    for (int k = 0; k < ends.n; ++k) {
        const glm::vec3& p = ends.point[size_t(k)];
        const __mmask16 m =
            __mmask16(segment & ~matched & near(ex, p.x) & near(ey, p.y) & near(ez, p.z));
        px = _mm512_mask_blend_ps(m, px, _mm512_set1_ps(p.x));
        py = _mm512_mask_blend_ps(m, py, _mm512_set1_ps(p.y));
        pz = _mm512_mask_blend_ps(m, pz, _mm512_set1_ps(p.z));
        if (which) *which = _mm512_mask_blend_epi32(m, *which, _mm512_set1_epi32(k));
        matched |= m;
    }
    r.ox = _mm512_mask_blend_ps(matched, r.ox, px);
    r.oy = _mm512_mask_blend_ps(matched, r.oy, py);
    r.oz = _mm512_mask_blend_ps(matched, r.oz, pz);
    r.tmax = _mm512_mask_blend_ps(matched, r.tmax, _mm512_sub_ps(r.tmax, r.tmin));
    r.tmin = _mm512_mask_blend_ps(matched, r.tmin, zero);
    r.dx = _mm512_mask_xor_ps(r.dx, matched, r.dx, signMask);
    r.dy = _mm512_mask_xor_ps(r.dy, matched, r.dy, signMask);
    r.dz = _mm512_mask_xor_ps(r.dz, matched, r.dz, signMask);
    return matched;
}

}  // namespace rayclass::classify

#endif
