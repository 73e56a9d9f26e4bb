#include "convert.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "rays16.h"

namespace rayclass::classify {

namespace {

#if defined(RC_AVX512_PATHS)
// The bounds of the points a block loop wrote, per face and coordinate, lane by lane.
struct Bounds16 {
    __m512 lo[kFaceCount][kCoords], hi[kFaceCount][kCoords];

    RC_AVX512 Bounds16() {
        for (int f = 0; f < kFaceCount; ++f) {
            for (int k = 0; k < kCoords; ++k) {
                lo[f][k] = _mm512_set1_ps(kInf);
                hi[f][k] = _mm512_set1_ps(-kInf);
            }
        }
    }
    // Grows faceBounds by them, and by the values held back (which were never compared here).
    RC_AVX512 void Fold(Bounds6* faceBounds, const HeldCoords& held) const {
        for (int f = 0; f < kFaceCount; ++f) {
            for (int k = 0; k < kCoords; ++k) {
                faceBounds[f].lo[k] = std::min(faceBounds[f].lo[k], ReduceMin(lo[f][k]));
                faceBounds[f].hi[k] = std::max(faceBounds[f].hi[k], ReduceMax(hi[f][k]));
            }
            if (held.seen[f]) GrowBounds(faceBounds[f], held.value[f]);
        }
    }
};
#endif

// Writes mapped rays at their face's next position, holding back the coordinates that have not
// varied among the face's rays so far.
class FaceWriter {
  public:
    FaceWriter(const FaceSlabs& out, uint32_t* next, Bounds6* faceBounds, HeldCoords& held,
               const Bounds3f& sceneBox)
        : out_(out), next_(next), faceBounds_(faceBounds), held_(held) {
        for (int f = 0; f < kFaceCount; ++f) {
            start_[f] = next[f];
            held.seen[f] = false;
            held.mask[f] = 0;
            // Ends beyond the box are cut where the face's X leaves it, so the rays that leave
            // the box share one end, which then stays a constant that partitions do not move.
            faceEnd_[f] = BoxInFace(f, sceneBox).hi[0];
        }
    }

    // A ray that ToRay5 maps.
    void Put(const Ray5& r, uint32_t id) {
        const int f = r.face;
        const uint32_t at = next_[f]++;
        const float p[kCoords] = {r.p[0], r.p[1], r.p[2],
                                  r.p[3], r.p[4], std::min(r.p[0] + r.reach, faceEnd_[f])};
        if (See(f)) std::copy_n(p, kCoords, held_.value[f]);
        for (int k = 0; k < kCoords; ++k) {
            if ((held_.mask[f] >> k) & 1u) {
                if (std::bit_cast<uint32_t>(p[k]) == std::bit_cast<uint32_t>(held_.value[f][k]))
                    continue;
                Release(f, k, at);
            }
            out_.coord[k][at] = p[k];
        }
        out_.id[at] = id;
        GrowBounds(faceBounds_[r.face], p);
    }

#if defined(RC_AVX512_PATHS)
    // Lanes m of the points p (all of face f) with ids `id`; their bounds grow `bounds`.
    RC_AVX512 void Put16(int f, __mmask16 m, const __m512 p[kCoords], __m512i id,
                         Bounds16& bounds) {
        const uint32_t cnt = uint32_t(std::popcount(unsigned(m)));
        const __mmask16 dst = __mmask16((1u << cnt) - 1u);
        const uint32_t w = next_[f];
        const bool first = See(f);
        const int firstLane = std::countr_zero(unsigned(m));
        for (int k = 0; k < kCoords; ++k) {
            if (first) {
                alignas(64) float lanes[16];
                _mm512_store_ps(lanes, p[k]);
                held_.value[f][k] = lanes[firstLane];
            }
            if ((held_.mask[f] >> k) & 1u) {
                // Compared in place, not compressed: a held coordinate (a light's position for
                // its shadow rays) usually stays held and is never stored. (Held values join the
                // bounds at the end.)
                const __m512i value = _mm512_set1_epi32(std::bit_cast<int32_t>(held_.value[f][k]));
                if (!_mm512_mask_cmpneq_epi32_mask(m, _mm512_castps_si512(p[k]), value)) continue;
                Release(f, k, w);
            }
            _mm512_mask_storeu_ps(out_.coord[k] + w, dst, _mm512_maskz_compress_ps(m, p[k]));
            bounds.lo[f][k] = _mm512_mask_min_ps(bounds.lo[f][k], m, bounds.lo[f][k], p[k]);
            bounds.hi[f][k] = _mm512_mask_max_ps(bounds.hi[f][k], m, bounds.hi[f][k], p[k]);
        }
        _mm512_mask_storeu_epi32(out_.id + w, dst, _mm512_maskz_compress_epi32(m, id));
        next_[f] = w + cnt;
    }
#endif

  private:
    // Face f's first ray: every coordinate is held until a ray differs there.
    bool See(int f) {
        const bool first = !held_.seen[f];
        held_.seen[f] = true;
        if (first) held_.mask[f] = (1u << kCoords) - 1u;
        return first;
    }
    // Coordinate k of face f differs from the held value at position `at`: the rays before it
    // get the value after all, and the coordinate is stored from then on.
    void Release(int f, int k, uint32_t at) {
        std::fill_n(out_.coord[k] + start_[f], at - start_[f], held_.value[f][k]);
        held_.mask[f] &= ~(1u << k);
    }

    const FaceSlabs& out_;
    uint32_t* next_;
    Bounds6* faceBounds_;
    HeldCoords& held_;
    uint32_t start_[kFaceCount];
    float faceEnd_[kFaceCount];
};

#if defined(RC_AVX512_PATHS)
// Where 16 rays start and the segments mapped from there. `fast`: the lanes the vector path maps;
// `rejected`: lanes that start outside the box and miss it. The others take the scalar path.
struct Start16 {
    __m512 p[3];
    __m512 segLo, segHi;
    __mmask16 fast, rejected;
};

// ToRay5Clipped's slab clip of the lanes `outside` (rays that start outside the box, whose
// origin is finite), operation for operation, so the points are bit-identical.
RC_AVX512 void ClipToBox16(const Rays16& r, __mmask16 outside, const __m512 blo[3],
                           const __m512 bhi[3], Start16& s) {
    const __m512 zero = _mm512_setzero_ps(), one = _mm512_set1_ps(1.0f);
    const __m512 o[3] = {r.ox, r.oy, r.oz}, d[3] = {r.dx, r.dy, r.dz};
    __m512 tEnter = r.tmin, tExit = r.tmax;
    __mmask16 clip = outside;
    for (int k = 0; k < 3; ++k) {
        // An axis-parallel ray misses unless it lies within the slab; it never narrows the
        // interval.
        const __mmask16 flat = _mm512_cmp_ps_mask(d[k], zero, _CMP_EQ_OQ);
        clip &= __mmask16(~(flat & (_mm512_cmp_ps_mask(o[k], blo[k], _CMP_LT_OQ) |
                                    _mm512_cmp_ps_mask(o[k], bhi[k], _CMP_GT_OQ))));
        const __m512 inv = _mm512_div_ps(one, _mm512_mask_blend_ps(flat, d[k], one));
        const __m512 t0 = _mm512_mul_ps(_mm512_sub_ps(blo[k], o[k]), inv);
        const __m512 t1 = _mm512_mul_ps(_mm512_sub_ps(bhi[k], o[k]), inv);
        // The ordered pair, then std::max(tEnter, near) and std::min(tExit, far).
        const __m512 near = Min16(t1, t0), far = Max16(t0, t1);
        tEnter = _mm512_mask_max_ps(tEnter, __mmask16(~flat), near, tEnter);
        tExit = _mm512_mask_min_ps(tExit, __mmask16(~flat), far, tExit);
    }
    clip &= _mm512_cmp_ps_mask(tEnter, tExit, _CMP_LE_OQ) &
            _mm512_cmp_ps_mask(tEnter, r.tmax, _CMP_LT_OQ);
    for (int k = 0; k < 3; ++k) {
        // glm::clamp(o + tEnter d, lo, hi) = min(max(., lo), hi).
        const __m512 p = _mm512_add_ps(o[k], _mm512_mul_ps(tEnter, d[k]));
        const __m512 clamped = Min16(bhi[k], Max16(blo[k], p));
        s.p[k] = _mm512_mask_blend_ps(clip, s.p[k], clamped);
    }
    s.segLo = _mm512_mask_blend_ps(clip, s.segLo, tEnter);
    s.segHi = _mm512_mask_blend_ps(clip, s.segHi, tExit);
    s.fast |= clip;
    s.rejected = __mmask16(outside & ~clip);
}

RC_AVX512 Start16 Starts16(const Rays16& r, const Axis16& axis, __mmask16 live, const __m512 blo[3],
                           const __m512 bhi[3]) {
    const __m512 zero = _mm512_setzero_ps();
    // start = tMin == 0 ? origin : origin + tMin d
    const __mmask16 t0 = _mm512_cmp_ps_mask(r.tmin, zero, _CMP_EQ_OQ);
    const __m512 sx =
        _mm512_mask_blend_ps(t0, _mm512_add_ps(r.ox, _mm512_mul_ps(r.tmin, r.dx)), r.ox);
    const __m512 sy =
        _mm512_mask_blend_ps(t0, _mm512_add_ps(r.oy, _mm512_mul_ps(r.tmin, r.dy)), r.oy);
    const __m512 sz =
        _mm512_mask_blend_ps(t0, _mm512_add_ps(r.oz, _mm512_mul_ps(r.tmin, r.dz)), r.oz);
    const __mmask16 inside = InBox16(sx, sy, sz, blo, bhi);
    const __mmask16 mappable = __mmask16(live & Mappable16(axis, r.dx, r.dy, r.dz));
    Start16 s{{sx, sy, sz},
              r.tmin,
              r.tmax,
              __mmask16(mappable & inside & _mm512_cmp_ps_mask(r.tmin, r.tmax, _CMP_LT_OQ)),
              0};
    const __m512 absMask = _mm512_castsi512_ps(_mm512_set1_epi32(0x7FFFFFFF));
    const __m512 osum = _mm512_add_ps(_mm512_add_ps(r.ox, r.oy), r.oz);
    const __mmask16 outside = __mmask16(
        mappable & ~inside &
        _mm512_cmp_ps_mask(_mm512_and_ps(osum, absMask), _mm512_set1_ps(kFloatMax), _CMP_LE_OQ));
    if (outside) ClipToBox16(r, outside, blo, bhi, s);
    return s;
}

// ConvertRays' blocks of 16 rays (the last one's missing lanes masked); lanes the vector path
// does not map take the scalar one. Returns the rays done.
RC_AVX512 size_t ConvertBlocks16(RayView rays, const CommonEnds& ends, const Bounds3f& sceneBox,
                                 uint32_t firstId, FaceWriter& writer, Bounds6* faceBounds,
                                 HeldCoords& held, std::vector<rc_uint>& missed,
                                 uint64_t& fromEnd) {
    const size_t n = rays.size();
    size_t i = 0;
    const RayStream16 stream(rays);
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const __m512 blo[3] = {_mm512_set1_ps(sceneBox.lo.x), _mm512_set1_ps(sceneBox.lo.y),
                           _mm512_set1_ps(sceneBox.lo.z)};
    const __m512 bhi[3] = {_mm512_set1_ps(sceneBox.hi.x), _mm512_set1_ps(sceneBox.hi.y),
                           _mm512_set1_ps(sceneBox.hi.z)};
    Bounds16 bounds;
    for (; i < n; i += 16) {
        const __mmask16 live = LiveLanes16(n, i);
        Rays16 r = stream.Load(i, live);
        fromEnd += uint64_t(std::popcount(unsigned(Orient16(ends, live, r))));
        const Axis16 axis = DominantAxis16(r.dx, r.dy, r.dz);
        const Start16 s = Starts16(r, axis, live, blo, bhi);
        const Point16 q =
            FacePoint16(s.p, r.dx, r.dy, r.dz, s.segLo, s.segHi, axis, s.fast, blo, bhi);
        const __m512 p[kCoords] = {q.x, q.y, q.z, q.u, q.v, q.end};
        const __m512i id = _mm512_add_epi32(_mm512_set1_epi32(int(firstId + i)), lane);
        // Faces 2a + neg; bucket the fast lanes of each face present.
        const __mmask16 byAxis[3] = {axis.isX, axis.isY, axis.isZ};
        for (int f = 0; f < kFaceCount; ++f) {
            const __mmask16 m =
                __mmask16(s.fast & byAxis[f >> 1] & ((f & 1) ? axis.neg : __mmask16(~axis.neg)));
            if (m) writer.Put16(f, m, p, id, bounds);
        }
        // The other lanes by the scalar path.
        for (unsigned slow = unsigned(live & ~s.fast); slow; slow &= slow - 1) {
            const int j = std::countr_zero(slow);
            const uint32_t rayId = firstId + uint32_t(i) + uint32_t(j);
            const Ray ray = ends.Oriented(rays[i + size_t(j)]);
            Ray5 r5;
            if (!((s.rejected >> j) & 1u) && DirectionFace(ray.direction) < kFaceCount &&
                ToRay5Clipped(ray, sceneBox, r5)) {
                writer.Put(r5, rayId);
            } else {
                missed.push_back(rayId);
            }
        }
    }
    bounds.Fold(faceBounds, held);
    return i;
}
#endif

}  // namespace

uint64_t ConvertRays(RayView rays, const CommonEnds& ends, const Bounds3f& sceneBox,
                     uint32_t firstId, const FaceSlabs& out, uint32_t* next, Bounds6* faceBounds,
                     HeldCoords& held, std::vector<rc_uint>& missed) {
    FaceWriter writer(out, next, faceBounds, held, sceneBox);
    uint64_t fromEnd = 0;
    const size_t n = rays.size();
    size_t i = 0;
#if defined(RC_AVX512_PATHS)
    if (UseAvx512())
        i = ConvertBlocks16(rays, ends, sceneBox, firstId, writer, faceBounds, held, missed,
                            fromEnd);
#endif
    for (; i < n; ++i) {
        Ray5 r;
        const int match = ends.Match(rays[i]);
        const Ray ray = ends.Oriented(rays[i], match);
        fromEnd += match >= 0 ? 1 : 0;
        if (DirectionFace(ray.direction) < kFaceCount && ToRay5(ray, sceneBox, r)) {
            writer.Put(r, firstId + uint32_t(i));
        } else {
            missed.push_back(firstId + uint32_t(i));
        }
    }
    return fromEnd;
}

}  // namespace rayclass::classify
