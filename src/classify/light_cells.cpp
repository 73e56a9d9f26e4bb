// Any-hit rays that end at common points (shadow rays to point lights) classified from the points
// by cells of their direction (LightCellSubdivision).
#include "light_cells.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstddef>
#include <numeric>

#include "filter.h"
#include "rays16.h"
#include "support.h"

namespace rayclass::classify {

namespace {

// The automatic grid: at least this many rays a cell if they filled every face evenly. Finer
// cells tighten the bounds, but cost their zeroing, pyramid and scattered counts; coarser ones
// lengthen the lists.
constexpr uint32_t kRaysPerCell = 8;
constexpr int kMinCellBits = 2, kMaxCellBits = 8;  // 4 to 256 cells a side (8-bit cell indices)

// A single cell whose list holds fewer candidates than this is a leaf, whatever the cost
// function says: refining reads its rays again and splits them one by one, which costs more than
// the cost function's split, and short lists gain little: refining every cell read a large
// share of a generation's rays again for a few percent fewer tests.
constexpr size_t kRefineCandidates = 256;

// The low 8 bits of x on the even bits of 16 (a cell's u goes to the odd ones).
constexpr uint32_t Spread(uint32_t x) {
    x = (x | (x << 4)) & 0x0F0Fu;
    x = (x | (x << 2)) & 0x3333u;
    return (x | (x << 1)) & 0x5555u;
}
// The even bits of x, packed.
constexpr uint32_t Compact(uint32_t x) {
    x &= 0x5555u;
    x = (x | (x >> 1)) & 0x3333u;
    x = (x | (x >> 2)) & 0x0F0Fu;
    return (x | (x >> 4)) & 0x00FFu;
}
static_assert(Compact(Spread(0xA5u)) == 0xA5u && Spread(0xFFu) == 0x5555u);

// Where level q (4^q entries) of a root's pyramid starts; LevelOffset(bits + 1) is its size.
constexpr size_t LevelOffset(int q) { return ((size_t(1) << (2 * q)) - 1) / 3; }

// Whether a ray that ends at none of the points misses everything, as Convert finds: its segment
// is empty, or its direction or origin is zero or not finite. Any other ray takes the general
// path.
bool Dead(const Ray& r) {
    return !(r.tMin < r.tMax) || DirectionFace(r.direction) == kFaceCount ||
           !std::isfinite(r.origin.x) || !std::isfinite(r.origin.y) || !std::isfinite(r.origin.z);
}

// The 5D point and end X of `ray`, which ends at point `match` of `ends`, taken from there through
// ToRay5's fast path (the vector loop's arithmetic); false when that path does not take it.
bool PointFromEnd(const CommonEnds& ends, int match, const Ray& ray, const Bounds3f& box, Ray5& p,
                  float& end) {
    const Ray o = ends.Oriented(ray, match);
    const glm::vec3& d = o.direction;
    if (!box.Contains(o.origin) || !(std::abs(d[DominantAxis(d)]) > 0.0f) ||
        !std::isfinite(d.x + d.y + d.z)) {
        return false;
    }
    ToRay5(o, box, p);
    end = std::min(p.p[0] + p.reach, BoxInFace(p.face, box).hi[0]);
    return true;
}

// The grid's cells a side, as a power of two, for nRays rays from `roots` points and faces.
int CellBits(uint32_t nRays, uint32_t roots, int lightCells) {
    if (lightCells > 0) return std::countr_zero(unsigned(lightCells));
    int bits = kMinCellBits;
    while (bits < kMaxCellBits && uint64_t(roots) * kRaysPerCell << (2 * bits) < nRays) ++bits;
    return bits;
}

const CellBox kEmptyCell{255, 0, 255, 0, -kInf};

// A root's cells, in key order: each cell's first position (`begin`, the root's size after the
// last) and its box; each piece's count of a cell becomes its first position there (within a
// cell, the pieces' rays follow the pieces before). Returns the root's size.
uint32_t PlaceRoot(uint32_t perRoot, size_t nPieces, uint32_t* const* counts,
                   const float* const* ends, uint32_t* begin, CellBox* cells) {
    uint32_t at = 0;
    for (uint32_t c = 0; c < perRoot; ++c) {
        begin[c] = at;
        float e = -kInf;
        for (size_t p = 0; p < nPieces; ++p) {
            const uint32_t count = counts[p][c];
            counts[p][c] = at;
            at += count;
            e = std::max(e, ends[p][c]);
        }
        const uint8_t u = uint8_t(Compact(c >> 1)), v = uint8_t(Compact(c));
        cells[c] = at > begin[c] ? CellBox{u, u, v, v, e} : kEmptyCell;
    }
    begin[perRoot] = at;
    return at;
}

// Starts a run of `key` at ray `first` unless the last run has that key.
inline void AddRun(KeyOut& out, uint32_t key, uint32_t first) {
    if (out.nRuns == 0 || out.runs[out.nRuns - 1].key != key) out.runs[out.nRuns++] = {key, first};
}

#if defined(RC_AVX512_PATHS)
// The keys of 16 rays: a ray's root (point * kFaceCount + face) above its (u, v) cell's bits,
// interleaved, u's first.
class CellKeyer16 {
  public:
    RC_AVX512 explicit CellKeyer16(int bits)
        : bits_(bits),
          half_(_mm512_set1_ps(float(1u << bits) * 0.5f)),
          top_(_mm512_set1_epi32((1 << bits) - 1)) {}

    // `which`: the point each lane ends at.
    RC_AVX512 __m512i Key(__m512i which, const Axis16& axes, __m512 u, __m512 v) const {
        const __m512i zero = _mm512_setzero_si512(), one = _mm512_set1_epi32(1);
        // face = 2 axis + (d_a < 0); root = point * kFaceCount + face
        const __m512i axis = _mm512_mask_blend_epi32(
            axes.isZ, _mm512_mask_blend_epi32(axes.isY, zero, one), _mm512_set1_epi32(2));
        const __m512i face = _mm512_mask_add_epi32(_mm512_add_epi32(axis, axis), axes.neg,
                                                   _mm512_add_epi32(axis, axis), one);
        const __m512i root =
            _mm512_add_epi32(_mm512_mullo_epi32(which, _mm512_set1_epi32(kFaceCount)), face);
        return _mm512_or_si512(
            _mm512_maskz_slli_epi32(kAll, root, unsigned(2 * bits_)),
            _mm512_or_si512(_mm512_maskz_slli_epi32(kAll, Spread(Cell(u)), 1), Spread(Cell(v))));
    }

  private:
    static constexpr __mmask16 kAll = 0xFFFF;

    // The cell of slope s: floor((s + 1) half), clamped to the grid.
    RC_AVX512 __m512i Cell(__m512 s) const {
        const __m512i c = _mm512_maskz_cvt_roundps_epi32(
            kAll, _mm512_mul_ps(_mm512_add_ps(s, _mm512_set1_ps(1.0f)), half_),
            _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
        return _mm512_maskz_min_epi32(kAll, _mm512_maskz_max_epi32(kAll, c, _mm512_setzero_si512()),
                                      top_);
    }
    // Spread of each lane.
    RC_AVX512 static __m512i Spread(__m512i x) {
        x = _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_slli_epi32(kAll, x, 4)),
                             _mm512_set1_epi32(0x0F0F));
        x = _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_slli_epi32(kAll, x, 2)),
                             _mm512_set1_epi32(0x3333));
        return _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_slli_epi32(kAll, x, 1)),
                                _mm512_set1_epi32(0x5555));
    }

    int bits_;
    __m512 half_;
    __m512i top_;
};

// Lanes of v moved up by `step`, zeros below (the zero-masked form: see Min16).
template <int step>
RC_AVX512 __m512 Up16(__m512 v) {
    return _mm512_castsi512_ps(_mm512_maskz_alignr_epi32(0xFFFF, _mm512_castps_si512(v),
                                                         _mm512_setzero_si512(), 16 - step));
}

// The lanes of k where a run of equal keys starts (lane 0 always).
RC_AVX512 unsigned RunStarts16(__m512i k) {
    const __m512i previous = _mm512_maskz_alignr_epi32(0xFFFF, k, _mm512_setzero_si512(), 15);
    return unsigned(_mm512_cmpneq_epi32_mask(k, previous)) | 1u;
}

// Adds the runs of equal keys k of the `live` lanes (the first ones) of a block of rays, the
// first `base`, to out.runs, and the lanes with a key (not kNoNode), ends e, to their cells'
// counts and largest ends. Neighbouring rays often share a cell, so each run updates its cell
// once (its length, and the largest end found by a segmented max over the run). The runs' bounds
// are bit masks in scalar registers: they cost no vector work.
RC_AVX512 void AddRuns16(__m512i k, __m512 e, __mmask16 live, uint32_t base, KeyOut& out) {
    const unsigned starts = RunStarts16(k) & live;
    const int nLive = std::bit_width(unsigned(live));
    // A lane takes the lane `step` below while no run starts in between: `near` holds the lanes
    // with a start among the `step` lanes up to them (lane 0 starts a run, so no lane reaches
    // below it).
    unsigned near = starts;
    __m512 runEnd = e;
    runEnd = _mm512_mask_max_ps(runEnd, __mmask16(~near), runEnd, Up16<1>(runEnd));
    near |= near << 1;
    runEnd = _mm512_mask_max_ps(runEnd, __mmask16(~near), runEnd, Up16<2>(runEnd));
    near |= near << 2;
    runEnd = _mm512_mask_max_ps(runEnd, __mmask16(~near), runEnd, Up16<4>(runEnd));
    near |= near << 4;
    runEnd = _mm512_mask_max_ps(runEnd, __mmask16(~near), runEnd, Up16<8>(runEnd));
    alignas(64) uint32_t key[16];
    alignas(64) float runMax[16];
    _mm512_store_si512(key, k);
    _mm512_store_ps(runMax, runEnd);
    // Locals: a store to a run could alias out.nRuns.
    CellRun* runs = out.runs;
    uint32_t* count = out.count;
    float* end = out.end;
    uint32_t n = out.nRuns;
    // Within the block each run's key differs from the one before; only the first may continue
    // the last block's run.
    if (n == 0 || runs[n - 1].key != key[0]) runs[n++] = {key[0], base};
    for (unsigned rest = starts; rest;) {
        const int first = std::countr_zero(rest);
        rest &= rest - 1;
        const int next = rest ? std::countr_zero(rest) : nLive;
        const uint32_t cell = key[first];
        if (first != 0) runs[n++] = {cell, base + uint32_t(first)};
        if (cell == kNoNode) continue;
        count[cell] += uint32_t(next - first);
        float* at = end + cell;
        // A max without a branch: a compare and jump around the store mispredicts.
        _mm_store_ss(at, _mm_max_ss(_mm_load_ss(at), _mm_load_ss(runMax + next - 1)));
    }
    out.nRuns = n;
}

// CellKeys' blocks of 16 rays: the conversion's fast path of ToRay5, operation for operation, on
// rays that all start at their point, inside the box. Sets `done` to the rays it took.
RC_AVX512 bool BlockKeys16(RayView rays, const CommonEnds& ends, const Bounds3f& box, int bits,
                           uint32_t firstId, KeyOut& out, std::vector<rc_uint>& missed,
                           uint64_t& fromEnd, size_t& done) {
    const RayStream16 stream(rays);
    const __m512 blo[3] = {_mm512_set1_ps(box.lo.x), _mm512_set1_ps(box.lo.y),
                           _mm512_set1_ps(box.lo.z)};
    const __m512 bhi[3] = {_mm512_set1_ps(box.hi.x), _mm512_set1_ps(box.hi.y),
                           _mm512_set1_ps(box.hi.z)};
    const CellKeyer16 keyer(bits);
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const size_t n = rays.size();
    size_t i = 0;
    for (; i < n; i += 16) {
        const __mmask16 live = LiveLanes16(n, i);
        Rays16 r = stream.Load(i, live);
        __m512i which = _mm512_setzero_si512();
        const __mmask16 matched = Orient16(ends, live, r, &which);
        if (const __mmask16 other = __mmask16(live & ~matched)) {
            // Empty segments (a share of a render's slots) miss without the scalar check.
            const __mmask16 empty =
                __mmask16(other & ~_mm512_cmp_ps_mask(r.tmin, r.tmax, _CMP_LT_OQ));
            for (unsigned rest = unsigned(other & ~empty); rest; rest &= rest - 1) {
                if (!Dead(rays[i + size_t(std::countr_zero(rest))])) return false;
            }
            alignas(64) rc_uint ids[16];
            _mm512_store_si512(
                ids,
                _mm512_maskz_compress_epi32(
                    other, _mm512_add_epi32(lane, _mm512_set1_epi32(int(firstId + uint32_t(i))))));
            missed.insert(missed.end(), ids, ids + std::popcount(unsigned(other)));
        }
        const Axis16 axes = DominantAxis16(r.dx, r.dy, r.dz);
        const __mmask16 fast = __mmask16(matched & InBox16(r.ox, r.oy, r.oz, blo, bhi) &
                                         Mappable16(axes, r.dx, r.dy, r.dz));
        if (matched & ~fast) return false;
        if (!fast) {
            AddRun(out, kNoNode, firstId + uint32_t(i));
            continue;
        }
        // (tMin is 0 once oriented, so the start is the origin.)
        const __m512 origin[3] = {r.ox, r.oy, r.oz};
        const Point16 p =
            FacePoint16(origin, r.dx, r.dy, r.dz, r.tmin, r.tmax, axes, fast, blo, bhi);
        // Rays that miss keep no key.
        const __m512i k =
            _mm512_mask_blend_epi32(fast, _mm512_set1_epi32(-1), keyer.Key(which, axes, p.u, p.v));
        AddRuns16(k, p.end, live, firstId + uint32_t(i), out);
        fromEnd += uint64_t(std::popcount(unsigned(fast)));
    }
    done = i;
    return true;
}

// SortRays' loop over a piece's runs: a run takes its positions with one update of its cell's
// next position and stores of its ids, which are consecutive, 16 at a time.
RC_AVX512 void SortRuns16(const CellRun* runs, uint32_t nRuns, int bits2, const uint32_t* rootBegin,
                          uint32_t* next, rc_uint* to) {
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    for (uint32_t r = 0; r < nRuns; ++r) {
        const uint32_t cell = runs[r].key;
        if (cell == kNoNode) continue;
        const uint32_t first = runs[r].first, len = runs[r + 1].first - first;
        uint32_t& at = next[cell];
        rc_uint* out = to + rootBegin[cell >> bits2] + at;
        at += len;
        __m512i ids = _mm512_add_epi32(lane, _mm512_set1_epi32(int(first)));
        for (uint32_t j = 0; j < len; j += 16) {
            const uint32_t rest = len - j;
            const __mmask16 m = rest >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << rest) - 1u);
            _mm512_mask_storeu_epi32(out + j, m, ids);
            ids = _mm512_add_epi32(ids, _mm512_set1_epi32(16));
        }
    }
}

// Compact of each lane.
RC_AVX512 __m512i Compact16(__m512i x) {
    constexpr __mmask16 kAll = 0xFFFF;
    x = _mm512_and_si512(x, _mm512_set1_epi32(0x5555));
    x = _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_srli_epi32(kAll, x, 1)),
                         _mm512_set1_epi32(0x3333));
    x = _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_srli_epi32(kAll, x, 2)),
                         _mm512_set1_epi32(0x0F0F));
    return _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_srli_epi32(kAll, x, 4)),
                            _mm512_set1_epi32(0x00FF));
}

// PlaceRoot, 16 cells at a time (a root has at least 16): the cells' positions from a prefix sum
// over the lanes, their boxes stored two vectors at a time.
RC_AVX512 uint32_t PlaceRoot16(uint32_t perRoot, size_t nPieces, uint32_t* const* counts,
                               const float* const* ends, uint32_t* begin, CellBox* cells) {
    static_assert(sizeof(CellBox) == 8 && offsetof(CellBox, end) == 4);
    constexpr __mmask16 kAll = 0xFFFF;
    const __m512i zero = _mm512_setzero_si512();
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    // An empty cell's (u, v) bytes (kEmptyCell), and the order of two cells' halves in memory.
    const __m512i emptyUv = _mm512_set1_epi32(0x00FF00FF);
    const __m512i low = _mm512_setr_epi32(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23);
    const __m512i high = _mm512_add_epi32(low, _mm512_set1_epi32(8));
    uint32_t at = 0;
    for (uint32_t c = 0; c < perRoot; c += 16) {
        __m512i total = zero;
        __m512 e = _mm512_set1_ps(-kInf);
        for (size_t p = 0; p < nPieces; ++p) {
            total = _mm512_add_epi32(total, _mm512_loadu_si512(counts[p] + c));
            e = Max16(e, _mm512_loadu_ps(ends[p] + c));
        }
        // The totals up to each lane, then the first position of each lane's cell.
        __m512i sum = total;
        sum = _mm512_add_epi32(sum, _mm512_maskz_alignr_epi32(kAll, sum, zero, 15));
        sum = _mm512_add_epi32(sum, _mm512_maskz_alignr_epi32(kAll, sum, zero, 14));
        sum = _mm512_add_epi32(sum, _mm512_maskz_alignr_epi32(kAll, sum, zero, 12));
        sum = _mm512_add_epi32(sum, _mm512_maskz_alignr_epi32(kAll, sum, zero, 8));
        __m512i first = _mm512_add_epi32(_mm512_sub_epi32(sum, total), _mm512_set1_epi32(int(at)));
        _mm512_storeu_si512(begin + c, first);
        for (size_t p = 0; p < nPieces; ++p) {
            const __m512i count = _mm512_loadu_si512(counts[p] + c);
            _mm512_storeu_si512(counts[p] + c, first);
            first = _mm512_add_epi32(first, count);
        }
        at += uint32_t(_mm_extract_epi32(_mm512_maskz_extracti32x4_epi32(0xF, sum, 3), 3));
        const __m512i cell = _mm512_add_epi32(lane, _mm512_set1_epi32(int(c)));
        const __m512i u = Compact16(_mm512_maskz_srli_epi32(kAll, cell, 1)), v = Compact16(cell);
        // uLo, uHi, vLo, vHi: u twice, then v twice.
        const __m512i uv = _mm512_mullo_epi32(
            _mm512_or_si512(u, _mm512_maskz_slli_epi32(kAll, v, 16)), _mm512_set1_epi32(0x0101));
        const __mmask16 full = _mm512_test_epi32_mask(total, total);
        const __m512i box = _mm512_mask_blend_epi32(full, emptyUv, uv);
        const __m512i end =
            _mm512_castps_si512(_mm512_mask_blend_ps(full, _mm512_set1_ps(-kInf), e));
        int32_t* to = reinterpret_cast<int32_t*>(cells + c);
        _mm512_storeu_si512(to, _mm512_permutex2var_epi32(box, low, end));
        _mm512_storeu_si512(to + 16, _mm512_permutex2var_epi32(box, high, end));
    }
    begin[perRoot] = at;
    return at;
}
#endif

CellBox Merge(const CellBox& a, const CellBox& b) {
    return {std::min(a.uLo, b.uLo), std::max(a.uHi, b.uHi), std::min(a.vLo, b.vLo),
            std::max(a.vHi, b.vHi), std::max(a.end, b.end)};
}

// The levels of a root's pyramid above its cells (its last level), from the cells up.
void BuildPyramid(CellBox* box, int bits) {
    for (int q = bits - 1; q >= 0; --q) {
        const CellBox* below = box + LevelOffset(q + 1);
        CellBox* level = box + LevelOffset(q);
        for (size_t j = 0; j < (size_t(1) << (2 * q)); ++j) {
            level[j] = Merge(Merge(below[4 * j], below[4 * j + 1]),
                             Merge(below[4 * j + 2], below[4 * j + 3]));
        }
    }
}

}  // namespace

bool LightCellSubdivision::Classify(const Generation& gen, LeafBatch& out) {
    if (core_.params.lightCells == 0 || gen.inserted.size() != 1 || core_.sceneBox.Empty()) {
        return false;
    }
    const auto& [rays, ends] = gen.inserted[0];
    // Only when the sample suggests that every ray ends at a point: a generation with others
    // finds out in the first pass over its rays and starts again on the general path.
    if (ends.n == 0 || !ends.coverSample || rays.size() == 0) return false;
    const uint32_t n = uint32_t(rays.size());
    CellGrid& g = cells_;
    g.rays = rays;
    g.ends = ends;
    g.roots = uint32_t(ends.n) * kFaceCount;
    g.bits = CellBits(n, g.roots, core_.params.lightCells);
    const int threads = core_.pool.Threads(n);
    const size_t step = (size_t(n) + size_t(threads) * 16 - 1) / (size_t(threads) * 16) * 16;
    const Pieces pieces{threads, step, (size_t(n) + step - 1) / step};
    std::vector<rc_uint> missed;
    uint64_t fromEnd = 0;
    if (!CountCells(pieces, missed, fromEnd)) return false;
    const uint32_t nLeafRays = PlaceCells(pieces);
    out.rayIndex.resize(nLeafRays);
    rayOut_ = out.rayIndex.data();
    SortRays(pieces);
    out.missed.insert(out.missed.end(), missed.begin(), missed.end());
    core_.counters.fromEnd += fromEnd;
    core_.counters.rayMoves = nLeafRays;
    core_.counters.cellsPerSide = 1u << g.bits;
    cones_.Use(g.ends);
    BuildRoots(nLeafRays, out);
    rayOut_ = nullptr;
    return true;
}

bool LightCellSubdivision::CountCells(const Pieces& pieces, std::vector<rc_uint>& missed,
                                      uint64_t& fromEnd) {
    CellGrid& g = cells_;
    const uint32_t n = uint32_t(g.rays.size());
    const size_t nKeys = size_t(g.roots) << (2 * g.bits);
    if (g.count.size() < pieces.count) {
        g.count.resize(pieces.count);
        g.end.resize(pieces.count);
    }
    if (g.runs.size() < pieces.count) g.runs.resize(pieces.count);
    g.nRuns.assign(pieces.count, 0);
    std::vector<std::vector<rc_uint>> pieceMissed(pieces.count);
    std::vector<uint64_t> pieceFromEnd(pieces.count, 0);
    std::atomic<bool> other{false};
    OnThreads(pieces.threads, [&](int t) {
        for (size_t p = size_t(t); p < pieces.count; p += size_t(pieces.threads)) {
            Regrow(g.count[p], nKeys);
            Regrow(g.end[p], nKeys);
            std::fill_n(g.count[p].data(), nKeys, 0u);
            std::fill_n(g.end[p].data(), nKeys, -kInf);
            const size_t at = p * pieces.step, len = std::min(pieces.step, size_t(n) - at);
            Regrow(g.runs[p], len + 1);
            KeyOut keyOut{g.runs[p].data(), g.count[p].data(), g.end[p].data()};
            if (!CellKeys(g.rays.Sub(at, len), g.ends, uint32_t(at), keyOut, pieceMissed[p],
                          pieceFromEnd[p])) {
                other = true;
            }
            g.nRuns[p] = keyOut.nRuns;
            keyOut.runs[keyOut.nRuns] = {kNoNode, uint32_t(at + len)};
        }
    });
    if (other) return false;
    for (size_t p = 0; p < pieces.count; ++p) {
        missed.insert(missed.end(), pieceMissed[p].begin(), pieceMissed[p].end());
        fromEnd += pieceFromEnd[p];
    }
    return true;
}

uint32_t LightCellSubdivision::PlaceCells(const Pieces& pieces) {
    CellGrid& g = cells_;
    const uint32_t perRoot = 1u << (2 * g.bits);
    const uint32_t stride = perRoot + 1;
    Regrow(g.begin, size_t(g.roots) * stride);
    const size_t pyramid = LevelOffset(g.bits + 1);
    Regrow(g.box, size_t(g.roots) * pyramid);
    g.rootBegin.assign(g.roots + 1, 0);
    std::atomic<uint32_t> nextRoot{0};
    OnThreads(pieces.threads, [&](int) {
        std::vector<uint32_t*> counts(pieces.count);
        std::vector<const float*> ends(pieces.count);
        for (uint32_t r; (r = nextRoot.fetch_add(1)) < g.roots;) {
            uint32_t* begin = g.begin.data() + size_t(r) * stride;
            CellBox* box = g.box.data() + size_t(r) * pyramid;
            CellBox* cells = box + LevelOffset(g.bits);
            for (size_t p = 0; p < pieces.count; ++p) {
                counts[p] = g.count[p].data() + size_t(r) * perRoot;
                ends[p] = g.end[p].data() + size_t(r) * perRoot;
            }
#if defined(RC_AVX512_PATHS)
            const auto place = UseAvx512() ? PlaceRoot16 : PlaceRoot;
#else
            const auto place = PlaceRoot;
#endif
            const uint32_t at =
                place(perRoot, pieces.count, counts.data(), ends.data(), begin, cells);
            g.rootBegin[r + 1] = at;  // the root's size, until summed below
            if (at > 0) BuildPyramid(box, g.bits);
        }
    });
    for (uint32_t r = 0; r < g.roots; ++r) g.rootBegin[r + 1] += g.rootBegin[r];
    return g.rootBegin[g.roots];
}

void LightCellSubdivision::SortRays(const Pieces& pieces) {
    CellGrid& g = cells_;
    const int bits2 = 2 * g.bits;
    OnThreads(pieces.threads, [&](int t) {
        for (size_t p = size_t(t); p < pieces.count; p += size_t(pieces.threads)) {
            uint32_t* next = g.count[p].data();
            const CellRun* runs = g.runs[p].data();
            const uint32_t nRuns = g.nRuns[p];
            const uint32_t* rootBegin = g.rootBegin.data();
#if defined(RC_AVX512_PATHS)
            if (UseAvx512()) {
                SortRuns16(runs, nRuns, bits2, rootBegin, next, rayOut_);
                continue;
            }
#endif
            for (uint32_t r = 0; r < nRuns; ++r) {
                const uint32_t cell = runs[r].key;
                if (cell == kNoNode) continue;
                const uint32_t first = runs[r].first, len = runs[r + 1].first - first;
                uint32_t& at = next[cell];
                std::iota(rayOut_ + rootBegin[cell >> bits2] + at,
                          rayOut_ + rootBegin[cell >> bits2] + at + len, first);
                at += len;
            }
        }
    });
}

void LightCellSubdivision::BuildRoots(uint32_t nLeafRays, LeafBatch& out) {
    CellGrid& g = cells_;
    for (uint32_t r = 0; r < g.roots; ++r) {
        const glm::vec3& point = g.ends.point[r / kFaceCount];
        const int face = int(r % kFaceCount), a = FaceAxis(face);
        g.origin[r][0] = FaceX(face, point);
        g.origin[r][1] = point[(a + 1) % 3];
        g.origin[r][2] = point[(a + 2) % 3];
    }
    WorkerPool& pool = core_.pool;
    const int threads = pool.Start(nLeafRays, pool.TaskCut(nLeafRays), out);
    if (refine_.size() < size_t(threads)) refine_.resize(size_t(threads));
    for (uint32_t r = 0; r < g.roots; ++r) {
        if (g.rootBegin[r] == g.rootBegin[r + 1]) continue;
        const ListView list = core_.faceLists->Whole(int(r % kFaceCount));
        pool.Queue(g.rootBegin[r], [this, r, list](Worker& w) {
            ProcessCells(w, CellAt{r, 0, 0}, list, false);
        });
    }
    pool.Run(threads);
    pool.Join(out, threads);
    pool.Finish(ScratchBytes(), core_.counters);
}

size_t LightCellSubdivision::ScratchBytes() const {
    const CellGrid& g = cells_;
    size_t bytes = g.begin.capacity() * 4 + g.box.capacity() * sizeof(CellBox) + cones_.Bytes();
    for (size_t p = 0; p < g.count.size(); ++p) {
        bytes += (g.count[p].capacity() + g.end[p].capacity()) * 4;
    }
    for (const auto& runs : g.runs) bytes += runs.capacity() * sizeof(CellRun);
    return bytes;
}

bool LightCellSubdivision::CellKeys(RayView rays, const CommonEnds& endsIn, uint32_t firstId,
                                    KeyOut& out, std::vector<rc_uint>& missed,
                                    uint64_t& fromEndOut) const {
    // Locals: the pieces' counters of rays taken from an end share a cache line, which updating
    // them in place a block at a time bounces between the cores; the copied points need no
    // reload after each store.
    const CommonEnds ends = endsIn;
    uint64_t fromEnd = 0;
    size_t i = 0;
#if defined(RC_AVX512_PATHS)
    if (UseAvx512() &&
        !BlockKeys16(rays, ends, core_.sceneBox, cells_.bits, firstId, out, missed, fromEnd, i)) {
        return false;
    }
#endif
    const int bits = cells_.bits;
    const float half = float(1u << bits) * 0.5f;
    const int top = (1 << bits) - 1;
    auto cellOf = [&](float s) {
        return uint32_t(std::clamp(int(std::floor((s + 1.0f) * half)), 0, top));
    };
    for (; i < rays.size(); ++i) {
        const Ray ray = rays[i];
        const int match = ends.Match(ray);
        if (match < 0) {
            if (!Dead(ray)) return false;
            AddRun(out, kNoNode, firstId + uint32_t(i));
            missed.push_back(firstId + uint32_t(i));
            continue;
        }
        Ray5 r5;
        float e;
        if (!PointFromEnd(ends, match, ray, core_.sceneBox, r5, e)) return false;
        const uint32_t key = (uint32_t(match * kFaceCount + r5.face) << (2 * bits)) |
                             Spread(cellOf(r5.p[3])) << 1 | Spread(cellOf(r5.p[4]));
        AddRun(out, key, firstId + uint32_t(i));
        ++out.count[key];
        out.end[key] = std::max(out.end[key], e);
        ++fromEnd;
    }
    fromEndOut = fromEnd;
    return true;
}

Bounds6 LightCellSubdivision::CellBounds(const CellAt& at) const {
    const CellGrid& g = cells_;
    const CellBox* level =
        g.box.data() + size_t(at.root) * LevelOffset(g.bits + 1) + LevelOffset((at.depth + 1) / 2);
    // An even depth is a node of the quadtree; an odd one halves one in u: two of the next level.
    const CellBox b = at.depth % 2 == 0 ? level[at.prefix]
                                        : Merge(level[2 * at.prefix], level[2 * at.prefix + 1]);
    const float size = 2.0f / float(1u << g.bits);
    Bounds6 t;
    for (int k = 0; k < 3; ++k) t.lo[k] = t.hi[k] = g.origin[at.root][k];
    t.lo[3] = float(b.uLo) * size - 1.0f - kCellPad;
    t.hi[3] = float(b.uHi + 1) * size - 1.0f + kCellPad;
    t.lo[4] = float(b.vLo) * size - 1.0f - kCellPad;
    t.hi[4] = float(b.vHi + 1) * size - 1.0f + kCellPad;
    t.lo[kDims] = t.lo[0];  // every ray ends at or beyond its start
    t.hi[kDims] = b.end;
    return t;
}

ListView LightCellSubdivision::Source(Worker& w, const CellAt& at, const Bounds6& tight,
                                      const ListView& list) {
    if (at.depth > LightCones::kDepth) return list;
    const ListView cone = cones_.List(at.root, at.prefix, at.depth, w.counters.boxTests);
    return CountUpTo(cone, tight.hi[kDims]) < CountUpTo(list, tight.hi[kDims]) ? cone : list;
}

void LightCellSubdivision::SpawnCells(const CellAt& at, const ListView& list, bool reuseList) {
    const uint32_t begin = cells_.rootBegin[at.root] +
                           cells_.begin[size_t(at.root) * ((size_t(1) << (2 * cells_.bits)) + 1) +
                                        (size_t(at.prefix) << (2 * cells_.bits - at.depth))];
    // `list` views a kept list or the face's: both outlive the task.
    core_.pool.Spawn(begin, [&](Part&) -> TaskBody {
        return [this, at, list, reuseList](Worker& w) { ProcessCells(w, at, list, reuseList); };
    });
}

void LightCellSubdivision::ProcessCells(Worker& w, CellAt at, const ListView& list,
                                        bool reuseList) {
    const int bits2 = 2 * cells_.bits;
    const uint32_t* cellBegin = cells_.begin.data() + size_t(at.root) * ((size_t(1) << bits2) + 1);
    const uint32_t rootBegin = cells_.rootBegin[at.root];
    // The first ray of node (prefix, depth), and of the one after it.
    auto first = [&](uint32_t prefix, int depth) {
        return rootBegin + cellBegin[size_t(prefix) << (bits2 - depth)];
    };
    const uint32_t begin = first(at.prefix, at.depth);
    const uint32_t nRays = first(at.prefix + 1, at.depth) - begin;
    if (nRays == 0) return;
    // A halving that leaves one side empty changes nothing: the node is its non-empty half.
    while (at.depth < bits2) {
        const uint32_t left = first(2 * at.prefix + 1, at.depth + 1) - begin;
        if (left != 0 && left != nRays) break;
        at.prefix = 2 * at.prefix + (left == 0 ? 1 : 0);
        ++at.depth;
    }
    const ArenaMark release(w.stack);
    const int face = int(at.root % kFaceCount);
    const Bounds6 tight = CellBounds(at);
    const bool spawns = nRays > core_.pool.Cut();
    const ListView from = reuseList ? list : Source(w, at, tight, list);
    const bool filtered = !reuseList && !KeepsMost(tight, from);
    ListView own = filtered ? w.Filter(tight, from, spawns) : CutAtEnd(tight, from);
    Node node;
    node.box = tight.ToBox5();
    node.face = uint8_t(face);
    node.depth = uint8_t(at.depth);
    int dim = 0;
    // A single cell is split further only when its list is long (see kRefineCandidates).
    const bool split = at.depth < bits2 || own.n >= kRefineCandidates;
    if (split &&
        core_.cost.ChooseSplit(node, tight, nRays, own, core_.params.lightMinCandidates, dim)) {
        if (at.depth == bits2) {
            RefineCell(w, at.root, begin, nRays, at.depth, own);
            return;
        }
        const bool reuse =
            filtered && (at.depth + 1) % std::max(core_.params.splitsPerList, 1) != 0;
        const CellAt left{at.root, 2 * at.prefix, at.depth + 1};
        const CellAt right{at.root, 2 * at.prefix + 1, at.depth + 1};
        // A node with many rays queues its right half, so that another thread can start on it.
        if (spawns) SpawnCells(right, own, reuse);
        ProcessCells(w, left, own, reuse);
        if (!spawns) ProcessCells(w, right, own, reuse);
        return;
    }
    if (!filtered) own = w.Filter(tight, from, false);
    RcLeaf leaf{};
    leaf.rayBegin = begin;
    leaf.rayCount = nRays;
    w.PushLeaf(leaf, w.NewNode(node.box, face, at.depth, false), own, tight.hi[kDims]);
}

void LightCellSubdivision::RefineCell(Worker& w, uint32_t root, uint32_t begin, uint32_t n,
                                      int depth, const ListView& list) {
    const CellGrid& g = cells_;
    std::vector<CellRay>& rays = refine_[size_t(w.index)];
    rays.resize(n);
    for (uint32_t j = 0; j < n; ++j) {
        // Mapped as CellKeys mapped it (which took every ray of a cell).
        const uint32_t id = rayOut_[begin + j];
        const Ray ray = g.rays[id];
        Ray5 p;
        float end = 0.0f;
        PointFromEnd(g.ends, g.ends.Match(ray), ray, core_.sceneBox, p, end);
        rays[j] = {p.p[3], p.p[4], end, id};
    }
    ProcessCellRays(w, root, rays.data(), n, begin, depth, list, true);
}

void LightCellSubdivision::ProcessCellRays(Worker& w, uint32_t root, CellRay* rays, uint32_t n,
                                           uint32_t slot, int depth, const ListView& list,
                                           bool reuseList) {
    const ArenaMark release(w.stack);
    const int face = int(root % kFaceCount);
    Bounds6 tight;
    for (int k = 0; k < 3; ++k) tight.lo[k] = tight.hi[k] = cells_.origin[root][k];
    tight.lo[3] = tight.lo[4] = kInf;
    tight.hi[3] = tight.hi[4] = tight.hi[kDims] = -kInf;
    for (uint32_t j = 0; j < n; ++j) {
        tight.lo[3] = std::min(tight.lo[3], rays[j].u);
        tight.hi[3] = std::max(tight.hi[3], rays[j].u);
        tight.lo[4] = std::min(tight.lo[4], rays[j].v);
        tight.hi[4] = std::max(tight.hi[4], rays[j].v);
        tight.hi[kDims] = std::max(tight.hi[kDims], rays[j].end);
    }
    tight.lo[kDims] = tight.lo[0];
    const bool filtered = !reuseList && !KeepsMost(tight, list);
    ListView own = filtered ? w.Filter(tight, list, false) : CutAtEnd(tight, list);
    Node node;
    node.box = tight.ToBox5();
    node.face = uint8_t(face);
    node.depth = uint8_t(std::min(depth, 255));
    int dim = 0;
    if (core_.cost.ChooseSplit(node, tight, n, own, core_.params.lightMinCandidates, dim)) {
        const float value = Midpoint(tight.lo[dim], tight.hi[dim]);
        CellRay* mid = std::partition(
            rays, rays + n, [&](const CellRay& r) { return (dim == 3 ? r.u : r.v) < value; });
        const uint32_t left = uint32_t(mid - rays);
        if (left > 0 && left < n) {
            const bool reuse =
                filtered && (depth + 1) % std::max(core_.params.splitsPerList, 1) != 0;
            ProcessCellRays(w, root, rays, left, slot, depth + 1, own, reuse);
            ProcessCellRays(w, root, mid, n - left, slot + left, depth + 1, own, reuse);
            return;
        }
    }
    if (!filtered) own = w.Filter(tight, list, false);
    for (uint32_t j = 0; j < n; ++j) rayOut_[slot + j] = rays[j].id;
    RcLeaf leaf{};
    leaf.rayBegin = slot;
    leaf.rayCount = n;
    w.PushLeaf(leaf, w.NewNode(node.box, face, node.depth, false), own, tight.hi[kDims]);
}

}  // namespace rayclass::classify
