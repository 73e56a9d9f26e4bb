#include "partition.h"

#include <algorithm>
#include <array>
#include <barrier>
#include <bit>
#include <utility>
#include <vector>

#include "avx512.h"

namespace rayclass::classify {

namespace {

#if defined(RC_AVX512_PATHS)
RC_AVX512 void MinMax16(const float* x, size_t n, float& lo, float& hi) {
    __m512 vlo = _mm512_set1_ps(kInf);
    __m512 vhi = _mm512_set1_ps(-kInf);
    size_t i = 0;
    for (; i + 16 <= n; i += 16) {
        const __m512 v = _mm512_loadu_ps(x + i);
        vlo = Min16(vlo, v);
        vhi = Max16(vhi, v);
    }
    if (i < n) {
        const __mmask16 live = __mmask16((1u << (n - i)) - 1u);
        vlo = _mm512_mask_min_ps(vlo, live, vlo, _mm512_maskz_loadu_ps(live, x + i));
        vhi = _mm512_mask_max_ps(vhi, live, vhi, _mm512_maskz_loadu_ps(live, x + i));
    }
    lo = ReduceMin(vlo);
    hi = ReduceMax(vhi);
}
#endif

}  // namespace

void MinMax(const float* x, size_t n, float& lo, float& hi) {
#if defined(RC_AVX512_PATHS)
    if (UseAvx512()) return MinMax16(x, n, lo, hi);
#endif
    float l = kInf, h = -kInf;
    for (size_t i = 0; i < n; ++i) {
        l = std::min(l, x[i]);
        h = std::max(h, x[i]);
    }
    lo = l;
    hi = h;
}

// Reads buffer `from` (coordinates and ids) and writes `to`; the key is the caller's.
PartitionIo Between(const ScratchVector<float>* from, ScratchVector<float>* to,
                    const ScratchVector<uint32_t>& fromId, ScratchVector<uint32_t>& toId) {
    PartitionIo io;
    for (int k = 0; k < kCoords; ++k) {
        io.src[k] = from[k].data();
        io.dst[k] = to[k].data();
    }
    io.srcId = fromId.data();
    io.dstId = toId.data();
    io.key = nullptr;
    return io;
}

namespace {

#if defined(RC_AVX512_PATHS)
// Calls f(std::integral_constant<int, k>) for each coordinate k set in kActive. Every index is
// then a constant, so the compiler keeps per-coordinate arrays of registers in registers: with a
// loop over k (even unrolled) GCC 12 also stored each accumulator to the stack on every block.
template <int kActive, typename F>
RC_AVX512 inline void ForActive(F&& f) {
    [&]<int... K>(std::integer_sequence<int, K...>) RC_AVX512 {
        ((((kActive >> K) & 1) ? f(std::integral_constant<int, K>{}) : void()), ...);
    }
    (std::make_integer_sequence<int, kCoords>{});
}

// kActive is a template argument so that the per-coordinate registers stay registers.
template <int kActive>
RC_AVX512 uint32_t PartitionRays16(const PartitionIo& io, float value, uint32_t begin, uint32_t end,
                                   Bounds6& leftBox, Bounds6& rightBox) {
    uint32_t l = begin, r = end;
    const __m512 m = _mm512_set1_ps(value);
    __m512 lLo[kCoords], lHi[kCoords], rLo[kCoords], rHi[kCoords];
    ForActive<kActive>([&](auto k) RC_AVX512 {
        lLo[k] = rLo[k] = _mm512_set1_ps(kInf);
        lHi[k] = rHi[k] = _mm512_set1_ps(-kInf);
    });
    // Local copies: stores through the destination pointers could otherwise alias `io`, and the
    // compiler would reload every pointer after every store.
    const float* src[kCoords];
    float* dst[kCoords];
    ForActive<kActive>([&](auto k) {
        src[k] = io.src[k];
        dst[k] = io.dst[k];
    });
    const float* const key = io.key;
    const uint32_t* const srcId = io.srcId;
    uint32_t* const dstId = io.dstId;
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    for (uint32_t i = begin; i < end; i += 16) {
        const uint32_t rest = end - i;
        const __mmask16 live = rest >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << rest) - 1u);
        const __m512 kv = _mm512_maskz_loadu_ps(live, key + i);
        const __mmask16 left = _mm512_mask_cmp_ps_mask(live, kv, m, _CMP_LT_OQ);
        const __mmask16 right = __mmask16(live & ~left);
        const uint32_t nl = uint32_t(std::popcount(unsigned(left)));
        const uint32_t nr = uint32_t(std::popcount(unsigned(right)));
        // One permutation puts the left lanes first and the right lanes last, each in lane
        // order, so each array costs one permute instead of two compresses (intersect_bench
        // BM_PartitionRays: 8-15 % faster with six or three arrays; maskz: GCC 12 warns of the
        // unmasked permute's undefined pass-through). The right lanes are stored from r - 16
        // under the mask of the top nr lanes: the lanes below, which may lie before the array,
        // are never written.
        const __mmask16 ml = __mmask16((1u << nl) - 1u);
        const __mmask16 top = __mmask16(0xFFFFu << (16 - nr));
        const __m512i order = _mm512_mask_compress_epi32(
            _mm512_maskz_expand_epi32(top, _mm512_maskz_compress_epi32(right, lane)), left, lane);
        const uintptr_t back = (uintptr_t(r) - 16) * sizeof(float);
        ForActive<kActive>([&](auto k) RC_AVX512 {
            const __m512 v = _mm512_maskz_loadu_ps(live, src[k] + i);
            const __m512 p = _mm512_maskz_permutexvar_ps(__mmask16(0xFFFF), order, v);
            _mm512_mask_storeu_ps(dst[k] + l, ml, p);
            _mm512_mask_storeu_ps(reinterpret_cast<void*>(uintptr_t(dst[k]) + back), top, p);
            lLo[k] = _mm512_mask_min_ps(lLo[k], left, lLo[k], v);
            lHi[k] = _mm512_mask_max_ps(lHi[k], left, lHi[k], v);
            rLo[k] = _mm512_mask_min_ps(rLo[k], right, rLo[k], v);
            rHi[k] = _mm512_mask_max_ps(rHi[k], right, rHi[k], v);
        });
        const __m512i id = _mm512_maskz_permutexvar_epi32(
            __mmask16(0xFFFF), order, _mm512_maskz_loadu_epi32(live, srcId + i));
        _mm512_mask_storeu_epi32(dstId + l, ml, id);
        _mm512_mask_storeu_epi32(reinterpret_cast<void*>(uintptr_t(dstId) + back), top, id);
        l += nl;
        r -= nr;
    }
    ForActive<kActive>([&](auto k) RC_AVX512 {
        leftBox.lo[k] = ReduceMin(lLo[k]);
        leftBox.hi[k] = ReduceMax(lHi[k]);
        rightBox.lo[k] = ReduceMin(rLo[k]);
        rightBox.hi[k] = ReduceMax(rHi[k]);
    });
    return l;
}
#endif

template <int kActive>
uint32_t PartitionRaysScalar(const PartitionIo& io, float value, uint32_t begin, uint32_t end,
                             Bounds6& leftBox, Bounds6& rightBox) {
    uint32_t l = begin, r = end;
    for (uint32_t i = begin; i < end; ++i) {
        const bool isLeft = io.key[i] < value;
        const uint32_t at = isLeft ? l : r - 1;
        for (int k = 0; k < kCoords; ++k) {
            if ((kActive >> k) & 1) io.dst[k][at] = io.src[k][i];
        }
        io.dstId[at] = io.srcId[i];
        l += isLeft ? 1 : 0;
        r -= isLeft ? 0 : 1;
    }
    for (int k = 0; k < kCoords; ++k) {
        if (!((kActive >> k) & 1)) continue;
        MinMax(io.dst[k] + begin, l - begin, leftBox.lo[k], leftBox.hi[k]);
        MinMax(io.dst[k] + l, end - l, rightBox.lo[k], rightBox.hi[k]);
    }
    return l;
}

template <int kActive = 0>
uint32_t DispatchPartition(int active, const PartitionIo& io, float value, uint32_t begin,
                           uint32_t end, Bounds6& leftBox, Bounds6& rightBox) {
    if constexpr (kActive == 1 << kCoords) {
        return begin;
    } else {
        if (active == kActive) {
#if defined(RC_AVX512_PATHS)
            if (UseAvx512())
                return PartitionRays16<kActive>(io, value, begin, end, leftBox, rightBox);
#endif
            return PartitionRaysScalar<kActive>(io, value, begin, end, leftBox, rightBox);
        }
        return DispatchPartition<kActive + 1>(active, io, value, begin, end, leftBox, rightBox);
    }
}

}  // namespace

uint32_t PartitionRays(int active, const PartitionIo& io, float value, uint32_t begin, uint32_t end,
                       Bounds6& leftBox, Bounds6& rightBox) {
    return DispatchPartition(active, io, value, begin, end, leftBox, rightBox);
}

namespace {

#if defined(RC_AVX512_PATHS)
RC_AVX512 bool AlreadySplit16(const float* key, float value, uint32_t begin, uint32_t end,
                              uint32_t* first, bool* firstLeft) {
    uint32_t changes = 0, run = end - begin;
    int prev = -1;
    const __m512 m = _mm512_set1_ps(value);
    for (uint32_t i = begin; i < end; i += 16) {
        const uint32_t lanes = std::min(16u, end - i);
        const __mmask16 live = __mmask16(lanes == 16 ? 0xFFFFu : (1u << lanes) - 1u);
        const unsigned left = unsigned(
            _mm512_mask_cmp_ps_mask(live, _mm512_maskz_loadu_ps(live, key + i), m, _CMP_LT_OQ));
        if (prev < 0) *firstLeft = left & 1u;
        if (prev >= 0 && int(left & 1u) != prev) {
            if (changes++ == 0) run = i - begin;
        }
        // Bit j: lanes j and j + 1 lie on different sides.
        const unsigned inner = (left ^ (left >> 1)) & ((1u << (lanes - 1)) - 1u);
        if (inner) {
            if (changes == 0) run = i - begin + uint32_t(std::countr_zero(inner)) + 1;
            changes += uint32_t(std::popcount(inner));
        }
        if (changes > 1) return false;
        prev = int((left >> (lanes - 1)) & 1u);
    }
    *first = run;
    return true;
}
#endif

}  // namespace

bool AlreadySplit(const float* key, float value, uint32_t begin, uint32_t end, uint32_t* first,
                  bool* firstLeft) {
#if defined(RC_AVX512_PATHS)
    if (UseAvx512()) return AlreadySplit16(key, value, begin, end, first, firstLeft);
#endif
    uint32_t changes = 0, run = end - begin;
    int prev = -1;
    for (uint32_t i = begin; i < end; ++i) {
        const int left = key[i] < value ? 1 : 0;
        if (prev < 0) *firstLeft = left;
        if (prev >= 0 && left != prev) {
            if (changes++ == 0) run = i - begin;
            if (changes > 1) return false;
        }
        prev = left;
    }
    *first = run;
    return true;
}

namespace {
#if defined(RC_AVX512_PATHS)
// The cells of `rule` of the 16 rays from i on, as cell numbers.
RC_AVX512 __m512i CellsOf16(const PartitionIo& io, const CellRule& rule, __m512 split, uint32_t i,
                            __mmask16 live) {
    const int firstCell = (1 << rule.levels) - 1;  // heap index of cell 0
    const __m512i one = _mm512_set1_epi32(1);
    __m512i h = _mm512_setzero_si512();
    for (int l = 0; l < rule.levels; ++l) {
        const __m512 key = _mm512_maskz_loadu_ps(live, io.src[rule.dim[l]] + i);
        // (maskz: GCC 12 warns of the plain form's undefined pass-through)
        const __m512 value = _mm512_maskz_permutexvar_ps(__mmask16(0xFFFF), h, split);
        const __mmask16 left = _mm512_cmp_ps_mask(key, value, _CMP_LT_OQ);
        h = _mm512_add_epi32(_mm512_add_epi32(h, h), one);
        h = _mm512_mask_add_epi32(h, __mmask16(~left), h, one);
    }
    return _mm512_sub_epi32(h, _mm512_set1_epi32(firstCell));
}

// The split values of `rule` in heap order, for CellsOf16.
RC_AVX512 __m512 SplitValues16(const CellRule& rule) {
    float values[16] = {};
    std::copy(rule.value, rule.value + (1 << rule.levels) - 1, values);
    return _mm512_loadu_ps(values);
}

// Calls f(c, lanes) for each cell c among the live lanes, with the lanes in it.
template <typename F>
RC_AVX512 void EachCell(__m512i cells, __mmask16 live, const F& f) {
    alignas(64) int32_t lane[16];
    _mm512_store_si512(lane, cells);
    unsigned rest = live;
    while (rest) {
        const int c = lane[std::countr_zero(rest)];
        const __mmask16 m =
            _mm512_mask_cmpeq_epi32_mask(__mmask16(rest), cells, _mm512_set1_epi32(c));
        f(c, m);
        rest &= ~unsigned(m);
    }
}

RC_AVX512 void CountCells16(const PartitionIo& io, const CellRule& rule, uint32_t begin,
                            uint32_t end, uint32_t* count) {
    const __m512 split = SplitValues16(rule);
    for (uint32_t i = begin; i < end; i += 16) {
        const __mmask16 live = LiveLanes16(end, i);
        EachCell(CellsOf16(io, rule, split, i, live), live, [&](int c, __mmask16 m) RC_AVX512 {
            count[c] += uint32_t(std::popcount(unsigned(m)));
        });
    }
}
#endif

int CellOf(const PartitionIo& io, const CellRule& rule, uint32_t i) {
    int h = 0;
    for (int l = 0; l < rule.levels; ++l)
        h = 2 * h + (io.src[rule.dim[l]][i] < rule.value[h] ? 1 : 2);
    return h - ((1 << rule.levels) - 1);
}

// Adds the rays [begin, end) of `io` to the counts of their cells of `rule`.
void CountCells(const PartitionIo& io, const CellRule& rule, uint32_t begin, uint32_t end,
                uint32_t* count) {
#if defined(RC_AVX512_PATHS)
    if (UseAvx512()) return CountCells16(io, rule, begin, end, count);
#endif
    for (uint32_t i = begin; i < end; ++i) ++count[CellOf(io, rule, i)];
}

// Writes the rays [begin, end) of `io` to their cells, cell c's from next[c] on in ray order, and
// gathers each cell's bounds of the active coordinates (the others are left empty).
#if defined(RC_AVX512_PATHS)
RC_AVX512 void ScatterCells16(const PartitionIo& io, const bool* active, const CellRule& rule,
                              uint32_t begin, uint32_t end, uint32_t* next, Bounds6* cell) {
    const int nCells = 1 << rule.levels;
    __m512 lo[16][kCoords], hi[16][kCoords];
    for (int c = 0; c < nCells; ++c) {
        for (int k = 0; k < kCoords; ++k) {
            lo[c][k] = _mm512_set1_ps(kInf);
            hi[c][k] = _mm512_set1_ps(-kInf);
        }
    }
    const __m512 split = SplitValues16(rule);
    for (uint32_t i = begin; i < end; i += 16) {
        const __mmask16 live = LiveLanes16(end, i);
        __m512 v[kCoords];
        for (int k = 0; k < kCoords; ++k) {
            v[k] = active[k] ? _mm512_maskz_loadu_ps(live, io.src[k] + i) : _mm512_setzero_ps();
        }
        const __m512i id = _mm512_maskz_loadu_epi32(live, io.srcId + i);
        EachCell(CellsOf16(io, rule, split, i, live), live, [&](int c, __mmask16 m) RC_AVX512 {
            const uint32_t n = uint32_t(std::popcount(unsigned(m)));
            const __mmask16 dst = __mmask16((1u << n) - 1u);
            for (int k = 0; k < kCoords; ++k) {
                if (!active[k]) continue;
                _mm512_mask_storeu_ps(io.dst[k] + next[c], dst, _mm512_maskz_compress_ps(m, v[k]));
                lo[c][k] = _mm512_mask_min_ps(lo[c][k], m, lo[c][k], v[k]);
                hi[c][k] = _mm512_mask_max_ps(hi[c][k], m, hi[c][k], v[k]);
            }
            _mm512_mask_storeu_epi32(io.dstId + next[c], dst, _mm512_maskz_compress_epi32(m, id));
            next[c] += n;
        });
    }
    for (int c = 0; c < nCells; ++c) {
        for (int k = 0; k < kCoords; ++k) {
            if (!active[k]) continue;
            cell[c].lo[k] = ReduceMin(lo[c][k]);
            cell[c].hi[k] = ReduceMax(hi[c][k]);
        }
    }
}
#endif

void ScatterCells(const PartitionIo& io, const bool* active, const CellRule& rule, uint32_t begin,
                  uint32_t end, uint32_t* next, Bounds6* cell) {
    const int nCells = 1 << rule.levels;
    for (int c = 0; c < nCells; ++c) cell[c] = EmptyBounds();
#if defined(RC_AVX512_PATHS)
    if (UseAvx512()) return ScatterCells16(io, active, rule, begin, end, next, cell);
#endif
    for (uint32_t i = begin; i < end; ++i) {
        const int c = CellOf(io, rule, i);
        const uint32_t at = next[c]++;
        for (int k = 0; k < kCoords; ++k) {
            if (!active[k]) continue;
            const float x = io.src[k][i];
            io.dst[k][at] = x;
            cell[c].lo[k] = std::min(cell[c].lo[k], x);
            cell[c].hi[k] = std::max(cell[c].hi[k], x);
        }
        io.dstId[at] = io.srcId[i];
    }
}

}  // namespace

void BucketRays(const PartitionIo& io, const bool* active, const CellRule& rule, uint32_t begin,
                uint32_t end, uint32_t* cellBegin, Bounds6* cell, int pieces) {
    const int nCells = 1 << rule.levels;
    // Runs of a multiple of 16 rays, so that the vector path sees the same blocks.
    const uint32_t step =
        ((end - begin + uint32_t(pieces) * 16 - 1) / (uint32_t(pieces) * 16)) * 16;
    std::vector<std::array<uint32_t, 16>> count(static_cast<size_t>(pieces));
    std::vector<std::array<Bounds6, 16>> bounds(static_cast<size_t>(pieces));
    std::barrier counted(pieces);
    OnThreadsAtOnce(pieces, [&](int t) {
        const uint32_t b = std::min(end, begin + uint32_t(t) * step);
        const uint32_t e = std::min(end, b + step);
        count[size_t(t)].fill(0);
        CountCells(io, rule, b, e, count[size_t(t)].data());
        counted.arrive_and_wait();
        // Piece t's rays of cell c follow the cell's rays of the earlier pieces.
        uint32_t next[16];
        uint32_t at = begin;
        for (int c = 0; c < nCells; ++c) {
            next[c] = at;
            for (int u = 0; u < pieces; ++u) {
                if (u == t) next[c] = at;
                at += count[size_t(u)][size_t(c)];
            }
            if (t == 0) cellBegin[c + 1] = at;
        }
        ScatterCells(io, active, rule, b, e, next, bounds[size_t(t)].data());
    });
    cellBegin[0] = begin;
    for (int c = 0; c < nCells; ++c) {
        cell[c] = bounds[0][size_t(c)];
        for (int t = 1; t < pieces; ++t) Merge(cell[c], bounds[size_t(t)][size_t(c)]);
    }
}

namespace {

#if defined(RC_AVX512_PATHS)
// GroupRays' first pass: each block of 16 rays' groups as two masks (box0's, box1's), kept in
// dest at the block's first position (positions are the task's own, so threads do not share
// them); count[g] gets each group's size.
RC_AVX512 void MarkGroups16(const PartitionIo& io, const bool* active, const float* constant,
                            const Box5& box0, const Box5& box1, uint32_t begin, uint32_t end,
                            uint32_t* dest, uint32_t count[3]) {
    __mmask16 in0 = 0xFFFF, in1 = 0xFFFF;  // what the coordinates that never vary allow
    for (int k = 0; k < kDims; ++k) {
        if (active[k]) continue;
        if (!(constant[k] >= box0.lo[k] && constant[k] <= box0.hi[k])) in0 = 0;
        if (!(constant[k] >= box1.lo[k] && constant[k] <= box1.hi[k])) in1 = 0;
    }
    for (uint32_t i = begin; i < end; i += 16) {
        const __mmask16 live = LiveLanes16(end, i);
        __mmask16 c0 = __mmask16(live & in0), c1 = __mmask16(live & in1);
        for (int k = 0; k < kDims; ++k) {
            if (!active[k]) continue;
            const __m512 v = _mm512_maskz_loadu_ps(live, io.src[k] + i);
            c0 = _mm512_mask_cmp_ps_mask(c0, v, _mm512_set1_ps(box0.lo[k]), _CMP_GE_OQ);
            c0 = _mm512_mask_cmp_ps_mask(c0, v, _mm512_set1_ps(box0.hi[k]), _CMP_LE_OQ);
            c1 = _mm512_mask_cmp_ps_mask(c1, v, _mm512_set1_ps(box1.lo[k]), _CMP_GE_OQ);
            c1 = _mm512_mask_cmp_ps_mask(c1, v, _mm512_set1_ps(box1.hi[k]), _CMP_LE_OQ);
        }
        c1 = __mmask16(c1 & ~c0);
        count[0] += uint32_t(std::popcount(unsigned(c0)));
        count[1] += uint32_t(std::popcount(unsigned(c1)));
        count[2] += uint32_t(std::popcount(unsigned(live & ~c0 & ~c1)));
        dest[i] = uint32_t(c0) | uint32_t(c1) << 16;
    }
}

// GroupRays' second pass: every group in ray order after the groups before it.
RC_AVX512 void MoveGroups16(const PartitionIo& io, const bool* active, uint32_t begin, uint32_t end,
                            const uint32_t* dest, const uint32_t count[3]) {
    uint32_t next[3] = {begin, begin + count[0], begin + count[0] + count[1]};
    for (uint32_t i = begin; i < end; i += 16) {
        const __mmask16 live = LiveLanes16(end, i);
        const __mmask16 group[3] = {__mmask16(dest[i]), __mmask16(dest[i] >> 16),
                                    __mmask16(live & ~(dest[i] | dest[i] >> 16))};
        for (int k = 0; k < kCoords; ++k) {
            if (!active[k]) continue;
            const __m512 v = _mm512_maskz_loadu_ps(live, io.src[k] + i);
            for (int g = 0; g < 3; ++g) {
                if (!group[g]) continue;
                const uint32_t n = uint32_t(std::popcount(unsigned(group[g])));
                _mm512_mask_storeu_ps(io.dst[k] + next[g], __mmask16((1u << n) - 1u),
                                      _mm512_maskz_compress_ps(group[g], v));
            }
        }
        const __m512i id = _mm512_maskz_loadu_epi32(live, io.srcId + i);
        for (int g = 0; g < 3; ++g) {
            if (!group[g]) continue;
            const uint32_t n = uint32_t(std::popcount(unsigned(group[g])));
            _mm512_mask_storeu_epi32(io.dstId + next[g], __mmask16((1u << n) - 1u),
                                     _mm512_maskz_compress_epi32(group[g], id));
            next[g] += n;
        }
    }
}
#endif

}  // namespace

void GroupRays(const PartitionIo& io, const bool* active, const float* constant, const Box5& box0,
               const Box5& box1, uint32_t begin, uint32_t end, uint32_t* dest, uint32_t count[3]) {
#if defined(RC_AVX512_PATHS)
    if (UseAvx512()) {
        MarkGroups16(io, active, constant, box0, box1, begin, end, dest, count);
        MoveGroups16(io, active, begin, end, dest, count);
        return;
    }
#endif
    for (uint32_t i = begin; i < end; ++i) {
        std::array<float, kDims> p;
        for (int k = 0; k < kDims; ++k) p[k] = active[k] ? io.src[k][i] : constant[k];
        const uint32_t g = box0.Contains(p) ? 0 : (box1.Contains(p) ? 1 : 2);
        dest[i] = g;
        ++count[g];
    }
    uint32_t next[3] = {begin, begin + count[0], begin + count[0] + count[1]};
    for (uint32_t i = begin; i < end; ++i) dest[i] = next[dest[i]]++;
    for (int k = 0; k < kCoords; ++k) {
        if (!active[k]) continue;
        for (uint32_t i = begin; i < end; ++i) io.dst[k][dest[i]] = io.src[k][i];
    }
    for (uint32_t i = begin; i < end; ++i) io.dstId[dest[i]] = io.srcId[i];
}

}  // namespace rayclass::classify
