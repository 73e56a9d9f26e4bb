// The 5D conversion of a generation's rays: each ray to its face's structure-of-arrays buffer
// (Hierarchy::Convert and ConvertAll).
#include <algorithm>
#include <bit>
#include <cmath>

#include "rayclass/classify/hierarchy.h"
#include "support.h"

#if defined(__AVX512F__)
#include "rays16.h"
#endif

namespace rayclass::classify {

uint64_t Hierarchy::Convert(RayView rays, const CommonEnds& ends, uint32_t firstId, uint32_t* next,
                            Bounds6* faceBounds, HeldCoords& held, std::vector<rc_uint>& missed) {
    uint64_t fromEnd = 0;
    float* c[kCoords];
    for (int k = 0; k < kCoords; ++k) c[k] = coord_[0][k].data();
    uint32_t* ids = id_[0].data();
    constexpr unsigned kAllCoords = (1u << kCoords) - 1u;
    uint32_t start[kFaceCount];
    for (int f = 0; f < kFaceCount; ++f) {
        start[f] = next[f];
        held.seen[f] = false;
        held.mask[f] = 0;
    }
    // Face f's first ray: every coordinate is held until a ray differs there.
    auto see = [&](int f) {
        const bool first = !held.seen[f];
        held.seen[f] = true;
        if (first) held.mask[f] = kAllCoords;
        return first;
    };
    // Coordinate k of face f differs from the held value at position `at`: the rays before it
    // get the value after all, and the coordinate is stored from then on.
    auto release = [&](int f, int k, uint32_t at) {
        std::fill_n(c[k] + start[f], at - start[f], held.value[f][k]);
        held.mask[f] &= ~(1u << k);
    };
    // Where each face's X leaves the scene box: ends beyond it are cut there, so the rays that
    // leave the box share one end, which then stays a constant that partitions do not move.
    float faceEnd[kFaceCount];
    for (int f = 0; f < kFaceCount; ++f) faceEnd[f] = BoxInFace(f, sceneBox_).hi[0];
    // A ray that ToRay5 maps: written at its face's next position.
    auto put = [&](const Ray5& r, uint32_t id) {
        const int f = r.face;
        const uint32_t at = next[f]++;
        const float p[kCoords] = {r.p[0], r.p[1], r.p[2],
                                  r.p[3], r.p[4], std::min(r.p[0] + r.reach, faceEnd[f])};
        if (see(f)) std::copy_n(p, kCoords, held.value[f]);
        for (int k = 0; k < kCoords; ++k) {
            if ((held.mask[f] >> k) & 1u) {
                if (std::bit_cast<uint32_t>(p[k]) == std::bit_cast<uint32_t>(held.value[f][k]))
                    continue;
                release(f, k, at);
            }
            c[k][at] = p[k];
        }
        ids[at] = id;
        GrowBounds(faceBounds[r.face], p);
    };
    const size_t n = rays.size();
    size_t i = 0;
#if defined(__AVX512F__)
    // The fast path of ToRay5 for 16 rays at a time, with the same float operations so the points
    // are bit-identical; lanes that need the slow path take the scalar one.
    const __m512i idx = RayOffsets16(rays);
    const bool packed = rays.Stride() == 8 * sizeof(float);
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const __m512 absMask = _mm512_castsi512_ps(_mm512_set1_epi32(0x7FFFFFFF));
    const __m512 fmax = _mm512_set1_ps(kFloatMax);
    const __m512 zero = _mm512_setzero_ps();
    const __m512 one = _mm512_set1_ps(1.0f);
    const __m512 blo[3] = {_mm512_set1_ps(sceneBox_.lo.x), _mm512_set1_ps(sceneBox_.lo.y),
                           _mm512_set1_ps(sceneBox_.lo.z)};
    const __m512 bhi[3] = {_mm512_set1_ps(sceneBox_.hi.x), _mm512_set1_ps(sceneBox_.hi.y),
                           _mm512_set1_ps(sceneBox_.hi.z)};
    __m512 accLo[kFaceCount][kCoords], accHi[kFaceCount][kCoords];
    for (int f = 0; f < kFaceCount; ++f) {
        for (int k = 0; k < kCoords; ++k) {
            accLo[f][k] = _mm512_set1_ps(kInf);
            accHi[f][k] = _mm512_set1_ps(-kInf);
        }
    }
    for (; i < n; i += 16) {
        const __mmask16 live = LiveLanes16(n, i);
        Rays16 r = packed ? Load16Packed(rays.Floats(i), std::min<size_t>(16, n - i))
                          : Gather16(rays.Floats(i), idx, live);
        fromEnd += uint64_t(std::popcount(unsigned(Orient16(ends, live, r))));
        const auto [ox, oy, oz, tmin, dx, dy, dz, tmax] = r;
        const Axis16 axis = DominantAxis16(dx, dy, dz);
        const auto [isX, isY, isZ, neg, ax, ay, az, da] = axis;
        // start = tMin == 0 ? origin : origin + tMin d
        const __mmask16 t0 = _mm512_cmp_ps_mask(tmin, zero, _CMP_EQ_OQ);
        const __m512 sx = _mm512_mask_blend_ps(t0, _mm512_add_ps(ox, _mm512_mul_ps(tmin, dx)), ox);
        const __m512 sy = _mm512_mask_blend_ps(t0, _mm512_add_ps(oy, _mm512_mul_ps(tmin, dy)), oy);
        const __m512 sz = _mm512_mask_blend_ps(t0, _mm512_add_ps(oz, _mm512_mul_ps(tmin, dz)), oz);
        const __mmask16 inside = InBox16(sx, sy, sz, blo, bhi);
        const __mmask16 mappable = __mmask16(live & Mappable16(axis, dx, dy, dz));
        __mmask16 fast = __mmask16(mappable & inside & _mm512_cmp_ps_mask(tmin, tmax, _CMP_LT_OQ));
        // Rays that start outside the box (the camera of a scene seen from outside, a light
        // beyond it): ToRay5Clipped's slab clip, operation for operation, so the points are
        // bit-identical. Lanes it rejects, and those with an origin that is not finite, take the
        // scalar path below.
        __m512 start[3] = {sx, sy, sz};
        __m512 segLo = tmin, segHi = tmax;
        __mmask16 rejected = 0;  // lanes the clip finds to miss the box, as ToRay5Clipped would
        const __m512 osum = _mm512_add_ps(_mm512_add_ps(ox, oy), oz);
        const __mmask16 outside =
            __mmask16(mappable & ~inside &
                      _mm512_cmp_ps_mask(_mm512_and_ps(osum, absMask), fmax, _CMP_LE_OQ));
        if (outside) {
            const __m512 o[3] = {ox, oy, oz}, d[3] = {dx, dy, dz};
            __m512 tEnter = tmin, tExit = tmax;
            __mmask16 clip = outside;
            for (int k = 0; k < 3; ++k) {
                // An axis-parallel ray misses unless it lies within the slab; it never narrows
                // the interval.
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
                    _mm512_cmp_ps_mask(tEnter, tmax, _CMP_LT_OQ);
            for (int k = 0; k < 3; ++k) {
                // glm::clamp(o + tEnter d, lo, hi) = min(max(., lo), hi).
                const __m512 p = _mm512_add_ps(o[k], _mm512_mul_ps(tEnter, d[k]));
                const __m512 clamped = Min16(bhi[k], Max16(blo[k], p));
                start[k] = _mm512_mask_blend_ps(clip, start[k], clamped);
            }
            segLo = _mm512_mask_blend_ps(clip, segLo, tEnter);
            segHi = _mm512_mask_blend_ps(clip, segHi, tExit);
            fast |= clip;
            rejected = __mmask16(outside & ~clip);
        }
        const Point16 q = FacePoint16(start, dx, dy, dz, segLo, segHi, axis, fast, blo, bhi);
        const __m512 p[kCoords] = {q.x, q.y, q.z, q.u, q.v, q.end};
        const __m512i id = _mm512_add_epi32(_mm512_set1_epi32(int(firstId + i)), lane);
        // Faces 2a + neg; bucket the fast lanes of each face present.
        const __mmask16 byAxis[3] = {isX, isY, isZ};
        for (int f = 0; f < kFaceCount; ++f) {
            const __mmask16 m =
                __mmask16(fast & byAxis[f >> 1] & ((f & 1) ? neg : __mmask16(~neg)));
            if (!m) continue;
            const uint32_t cnt = uint32_t(std::popcount(unsigned(m)));
            const __mmask16 dst = __mmask16((1u << cnt) - 1u);
            const uint32_t w = next[f];
            const bool first = see(f);
            const int firstLane = std::countr_zero(unsigned(m));
            for (int k = 0; k < kCoords; ++k) {
                if (first) {
                    alignas(64) float lanes[16];
                    _mm512_store_ps(lanes, p[k]);
                    held.value[f][k] = lanes[firstLane];
                }
                if ((held.mask[f] >> k) & 1u) {
                    // Compared in place, not compressed: a held coordinate (a light's position
                    // for its shadow rays) usually stays held and is never stored. (Held values
                    // join the bounds at the end.)
                    const __m512i value =
                        _mm512_set1_epi32(std::bit_cast<int32_t>(held.value[f][k]));
                    if (!_mm512_mask_cmpneq_epi32_mask(m, _mm512_castps_si512(p[k]), value))
                        continue;
                    release(f, k, w);
                }
                _mm512_mask_storeu_ps(c[k] + w, dst, _mm512_maskz_compress_ps(m, p[k]));
                accLo[f][k] = _mm512_mask_min_ps(accLo[f][k], m, accLo[f][k], p[k]);
                accHi[f][k] = _mm512_mask_max_ps(accHi[f][k], m, accHi[f][k], p[k]);
            }
            _mm512_mask_storeu_epi32(ids + w, dst, _mm512_maskz_compress_epi32(m, id));
            next[f] = w + cnt;
        }
        unsigned slow = unsigned(live & ~fast);
        while (slow) {
            const int j = std::countr_zero(slow);
            slow &= slow - 1;
            if ((rejected >> j) & 1u) {
                missed.push_back(firstId + uint32_t(i) + uint32_t(j));
                continue;
            }
            const Ray ray = ends.Oriented(rays[i + size_t(j)]);
            Ray5 r5;
            if (DirectionFace(ray.direction) < kFaceCount && ToRay5Clipped(ray, sceneBox_, r5)) {
                put(r5, firstId + uint32_t(i) + uint32_t(j));
            } else {
                missed.push_back(firstId + uint32_t(i) + uint32_t(j));
            }
        }
    }
    for (int f = 0; f < kFaceCount; ++f) {
        for (int k = 0; k < kCoords; ++k) {
            faceBounds[f].lo[k] = std::min(faceBounds[f].lo[k], ReduceMin(accLo[f][k]));
            faceBounds[f].hi[k] = std::max(faceBounds[f].hi[k], ReduceMax(accHi[f][k]));
        }
        if (held.seen[f]) GrowBounds(faceBounds[f], held.value[f]);
    }
#endif
    for (; i < n; ++i) {
        Ray5 r;
        const int match = ends.Match(rays[i]);
        const Ray ray = ends.Oriented(rays[i], match);
        fromEnd += match >= 0 ? 1 : 0;
        if (DirectionFace(ray.direction) < kFaceCount && ToRay5(ray, sceneBox_, r)) {
            put(r, firstId + uint32_t(i));
        } else {
            missed.push_back(firstId + uint32_t(i));
        }
    }
    return fromEnd;
}

void Hierarchy::ConvertAll(uint32_t* faceBegin, uint32_t* faceEnd, Bounds6* faceBounds,
                           LeafBatch& out) {
    for (int f = 0; f < kFaceCount; ++f) faceBounds[f] = EmptyBounds();
    const uint32_t n = nInserted_;
    for (int f = 0; f < kFaceCount; ++f) faceBegin[f] = faceEnd[f] = f * n;
    if (sceneBox_.Empty()) {
        for (uint32_t i = 0; i < n; ++i) out.missed.push_back(i);
        return;
    }
    // Every inserted array in `threads` pieces, each mapping its rays straight into the
    // structure-of-arrays buffer in one pass over them. Face f's rays go to the slab
    // [f n, (f + 1) n), where a piece writes from its first ray's id on: room for all of its
    // rays, so no pass is needed to count the faces first. The pieces' runs are then moved down
    // to follow each other: faces in their slabs, pieces in order within a face. The slabs are
    // address space: only the pages rays are written to are ever touched.
    const int threads = Threads(n);
    struct Piece {
        RayView rays;
        const CommonEnds* ends;
        uint32_t firstId;
        uint64_t fromEnd = 0;
        uint32_t start[kFaceCount], next[kFaceCount];
        Bounds6 bounds[kFaceCount];
        HeldCoords held;
        std::vector<rc_uint> missed;
    };
    std::vector<Piece> pieces;
    uint32_t firstId = 0;
    for (const auto& [rays, ends] : inserted_) {
        // Pieces start at multiples of 16 rays: Convert places the rays its slow path maps
        // after the others of their run of 16, so the runs must not depend on the thread count.
        const size_t step = (rays.size() + size_t(threads) * 16 - 1) / (size_t(threads) * 16) * 16;
        for (size_t at = 0; at < rays.size(); at += step) {
            Piece& p = pieces.emplace_back();
            p.rays = rays.Sub(at, std::min(step, rays.size() - at));
            p.ends = &ends;
            p.firstId = firstId + uint32_t(at);
            for (int f = 0; f < kFaceCount; ++f) p.start[f] = p.next[f] = f * n + p.firstId;
        }
        firstId += uint32_t(rays.size());
    }
    const size_t slabs = size_t(kFaceCount) * n;
    for (int b = 0; b < 2; ++b) {
        for (auto& c : coord_[b]) Regrow(c, slabs);
        Regrow(id_[b], slabs);
    }
    Regrow(dest_, slabs);
    OnThreads(threads, [&](int t) {
        for (size_t i = size_t(t); i < pieces.size(); i += size_t(threads)) {
            Piece& p = pieces[i];
            for (auto& b : p.bounds) b = EmptyBounds();
            p.fromEnd = Convert(p.rays, *p.ends, p.firstId, p.next, p.bounds, p.held, p.missed);
        }
    });
    bool moves = false;
    for (int f = 0; f < kFaceCount; ++f) {
        for (const Piece& p : pieces) {
            moves = moves || (p.next[f] > p.start[f] && p.start[f] != faceEnd[f]);
            faceEnd[f] += p.next[f] - p.start[f];
            Merge(faceBounds[f], p.bounds[f]);
        }
    }
    // A coordinate a piece held that varies over the face after all (pieces agreed on
    // different values) is read from now on: it gets its value.
    for (int f = 0; f < kFaceCount; ++f) {
        for (const Piece& p : pieces) {
            for (int k = 0; k < kCoords; ++k) {
                if (((p.held.mask[f] >> k) & 1u) && Varies(faceBounds[f], k))
                    std::fill_n(coord_[0][k].data() + p.start[f], p.next[f] - p.start[f],
                                p.held.value[f][k]);
            }
        }
    }
    if (moves) {
        // Each face's arrays apart (the coordinates and the ids), spread over the threads.
        constexpr int kArrays = kCoords + 1;
        OnThreads(threads, [&](int t) {
            for (int job = t; job < kFaceCount * kArrays; job += threads) {
                const int f = job / kArrays, k = job % kArrays;
                auto move = [&](auto* a) {
                    uint32_t to = faceBegin[f];
                    for (const Piece& p : pieces) {
                        const uint32_t len = p.next[f] - p.start[f];
                        // Runs only move down: the runs before one hold at most their pieces'
                        // rays, so a forward copy never overwrites what it has still to read.
                        if (to != p.start[f]) std::copy_n(a + p.start[f], len, a + to);
                        to += len;
                    }
                };
                if (k < kCoords) {
                    if (Varies(faceBounds[f], k)) move(coord_[0][k].data());
                } else {
                    move(id_[0].data());
                }
            }
        });
    }
    for (Piece& p : pieces) {
        out.missed.insert(out.missed.end(), p.missed.begin(), p.missed.end());
        counters_.fromEnd += p.fromEnd;
    }
    // The pieces come in id order and so do their misses: usually nothing is left to sort.
    if (!std::is_sorted(out.missed.begin(), out.missed.end()))
        std::sort(out.missed.begin(), out.missed.end());
}

}  // namespace rayclass::classify
