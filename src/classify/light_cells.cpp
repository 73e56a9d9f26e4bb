// Any-hit rays that end at common points (shadow rays to point lights) classified from the points
// by cells of their direction (Hierarchy::SubdivideFromEnds).
//
// From its point, a light's rays share their origin: only their direction and their end vary.
// The general path moves every ray once a level (or a plan's four levels) and reads it again for
// each node's bounds; here one counting sort puts the rays in the order of their cells, the
// cells' (u, v) bits interleaved, so that every node of the hierarchy is a range of cells and of
// rays, and a pyramid over the cells gives any node's bounds without reading a ray. A node's
// (u, v) bounds are those of its non-empty cells, so they are looser than its rays' by up to a
// cell on each side: the grid is fine enough that leaves span several cells. A single cell with
// a long list that the cost function would still split (a thin cone through dense geometry) is
// split ray by ray below the grid, its rays read again: without that, one 55-ray cell of
// Conference's anchor shadow rays kept a list of 103,300 candidates.
//
// Measured on Sibenik's and Conference's 786,432 anchor shadow rays, two cores, 128 cells a
// side (classify_bench, 5 runs alternating with light-cells=off): 7.6-8.6 against 12.0-13.5 ns
// a ray and 10.2-12.6 against 14.0-16.5, for 9.68 against 9.30 and 5.80 against 5.56 tests a
// ray.
#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>

#include "filter.h"
#include "rayclass/classify/hierarchy.h"
#include "support.h"

#if defined(__AVX512F__) && defined(__AVX512CD__)
#define RC_CELLS_AVX512 1
#include "rays16.h"
#endif

namespace rayclass::classify {

namespace {

// The automatic grid: at least this many rays a cell if they filled every face evenly. Finer
// cells tighten the bounds, but cost their zeroing, pyramid and scattered counts: on Sibenik's
// 786,432 anchor shadow rays 128 cells a side (8 a cell) classified in 9.6-12.8 ns a ray for
// 9.68 tests a ray, 256 (4 a cell) in 15.5-16.4 ns for 9.49 tests, 64 in 9.7-10.1 ns for 11.18.
constexpr uint32_t kRaysPerCell = 8;
constexpr int kMinCellBits = 2, kMaxCellBits = 8;  // 4 to 256 cells a side (8-bit cell indices)

// A single cell whose list holds fewer candidates than this is a leaf, whatever the cost
// function says: refining reads its rays again and splits them one by one, which costs more than
// the cost function's split, and short lists gain little. raybench, 786,432 shadow rays, host ms
// and tests a ray with a minimum of 0 / 256 / 1024 / never: Sibenik reverse camera 12.4 / 5.8 /
// 5.2 / 6.2 ms (refining 400k rays at 0), 6.31 / 6.38 / 6.41 / 6.41 tests; Conference anchor
// 14.3 / 10.1 / 12.2 / 9.2 ms, 6.92 / 7.04 / 7.50 / 7.53 tests, reverse 8.7 / 7.3 / 7.2 / 6.5
// ms, 8.23 / 8.48 / 9.24 / 9.35 tests (one run each, kernels too noisy to compare).
constexpr size_t kRefineCandidates = 256;

// A cell's bounds grow by this on each side: (u + 1) rounds by at most 2^-24 for |u| <= 1, so u
// lies at most that far outside the cell its rounded value picks.
constexpr float kCellPad = 1.0f / float(1 << 20);

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

// The grid's cells a side, as a power of two, for nRays rays from `roots` points and faces.
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

int CellBits(uint32_t nRays, uint32_t roots, int lightCells) {
    if (lightCells > 0) return std::countr_zero(unsigned(lightCells));
    int bits = kMinCellBits;
    while (bits < kMaxCellBits && uint64_t(roots) * kRaysPerCell << (2 * bits) < nRays) ++bits;
    return bits;
}

const CellBox kEmptyCell{255, 0, 255, 0, -kInf};

CellBox Merge(const CellBox& a, const CellBox& b) {
    return {std::min(a.uLo, b.uLo), std::max(a.uHi, b.uHi), std::min(a.vLo, b.vLo),
            std::max(a.vHi, b.vHi), std::max(a.end, b.end)};
}

}  // namespace

bool Hierarchy::SubdivideFromEnds(LeafBatch& out) {
    if (params_.lightCells == 0 || inserted_.size() != 1 || sceneBox_.Empty()) return false;
    const auto& [rays, ends] = inserted_[0];
    // Only when the sample suggests that every ray ends at a point: a generation with others
    // finds out in the first pass over its rays and starts again on the general path.
    if (ends.n == 0 || !ends.coverSample || rays.size() == 0) return false;
    const uint32_t n = uint32_t(rays.size());
    CellGrid& g = cells_;
    g.rays = rays;
    g.ends = ends;
    g.roots = uint32_t(ends.n) * kFaceCount;
    g.bits = CellBits(n, g.roots, params_.lightCells);
    const int bits2 = 2 * g.bits;
    const uint32_t perRoot = 1u << bits2;
    const size_t nKeys = size_t(g.roots) * perRoot;

    // Pass 1, in pieces of whole blocks of 16 rays: each ray's key, and per piece each cell's
    // count and largest end.
    const int threads = Threads(n);
    const size_t step = (size_t(n) + size_t(threads) * 16 - 1) / (size_t(threads) * 16) * 16;
    const size_t pieces = (size_t(n) + step - 1) / step;
    if (g.count.size() < pieces) {
        g.count.resize(pieces);
        g.end.resize(pieces);
    }
    Regrow(g.key, n);
    std::vector<std::vector<rc_uint>> missed(pieces);
    std::vector<uint64_t> fromEnd(pieces, 0);
    std::atomic<bool> other{false};
    OnThreads(threads, [&](int t) {
        for (size_t p = size_t(t); p < pieces; p += size_t(threads)) {
            Regrow(g.count[p], nKeys);
            Regrow(g.end[p], nKeys);
            std::fill_n(g.count[p].data(), nKeys, 0u);
            std::fill_n(g.end[p].data(), nKeys, -kInf);
            const size_t at = p * step, len = std::min(step, size_t(n) - at);
            if (!CellKeys(rays.Sub(at, len), ends, uint32_t(at), g.key.data() + at,
                          g.count[p].data(), g.end[p].data(), missed[p], fromEnd[p])) {
                other = true;
            }
        }
    });
    if (other) return false;

    // Within a root, each cell's rays follow the cells before, and within a cell each piece's
    // the pieces before (so a cell's rays keep their order); the counts become each piece's
    // next position, and each root gets its pyramid.
    const uint32_t stride = perRoot + 1;
    Regrow(g.begin, size_t(g.roots) * stride);
    const size_t pyramid = LevelOffset(g.bits + 1);
    Regrow(g.box, size_t(g.roots) * pyramid);
    g.rootBegin.assign(g.roots + 1, 0);
    std::atomic<uint32_t> nextRoot{0};
    OnThreads(threads, [&](int) {
        std::vector<uint32_t*> counts(pieces);
        std::vector<const float*> ends(pieces);
        for (uint32_t r; (r = nextRoot.fetch_add(1)) < g.roots;) {
            uint32_t* begin = g.begin.data() + size_t(r) * stride;
            CellBox* box = g.box.data() + size_t(r) * pyramid;
            CellBox* cells = box + LevelOffset(g.bits);
            for (size_t p = 0; p < pieces; ++p) {
                counts[p] = g.count[p].data() + size_t(r) * perRoot;
                ends[p] = g.end[p].data() + size_t(r) * perRoot;
            }
            uint32_t at = 0;
            for (uint32_t c = 0; c < perRoot; ++c) {
                begin[c] = at;
                float e = -kInf;
                for (size_t p = 0; p < pieces; ++p) {
                    const uint32_t count = counts[p][c];
                    counts[p][c] = at;
                    at += count;
                    e = std::max(e, ends[p][c]);
                }
                const uint8_t u = uint8_t(Compact(c >> 1)), v = uint8_t(Compact(c));
                cells[c] = at > begin[c] ? CellBox{u, u, v, v, e} : kEmptyCell;
            }
            begin[perRoot] = at;
            g.rootBegin[r + 1] = at;  // the root's size, until summed below
            if (at == 0) continue;
            for (int q = g.bits - 1; q >= 0; --q) {
                const CellBox* below = box + LevelOffset(q + 1);
                CellBox* level = box + LevelOffset(q);
                for (size_t j = 0; j < (size_t(1) << (2 * q)); ++j) {
                    level[j] = Merge(Merge(below[4 * j], below[4 * j + 1]),
                                     Merge(below[4 * j + 2], below[4 * j + 3]));
                }
            }
        }
    });
    for (uint32_t r = 0; r < g.roots; ++r) g.rootBegin[r + 1] += g.rootBegin[r];
    const uint32_t nLeafRays = g.rootBegin[g.roots];

    // Pass 2: the rays' ids in key order, straight into the leaves' ray array.
    out.rayIndex.resize(nLeafRays);
    rayOut_ = out.rayIndex.data();
    OnThreads(threads, [&](int t) {
        for (size_t p = size_t(t); p < pieces; p += size_t(threads)) {
            uint32_t* next = g.count[p].data();
            const uint32_t* key = g.key.data();
            const uint32_t* rootBegin = g.rootBegin.data();
            rc_uint* to = rayOut_;
            const uint32_t end = uint32_t(std::min(size_t(n), (p + 1) * step));
            for (uint32_t i = uint32_t(p * step); i < end; ++i) {
                const uint32_t k = key[i];
                if (k != kNoNode) to[rootBegin[k >> bits2] + next[k]++] = i;
            }
        }
    });
    for (size_t p = 0; p < pieces; ++p) {
        out.missed.insert(out.missed.end(), missed[p].begin(), missed[p].end());
        counters_.fromEnd += fromEnd[p];
    }
    counters_.rayMoves = nLeafRays;
    counters_.cellsPerSide = 1u << g.bits;

    // The hierarchy: a task per root (point and face) with rays.
    for (uint32_t r = 0; r < g.roots; ++r) {
        const glm::vec3& point = ends.point[r / kFaceCount];
        const int face = int(r % kFaceCount), a = FaceAxis(face);
        g.origin[r][0] = FaceX(face, point);
        g.origin[r][1] = point[(a + 1) % 3];
        g.origin[r][2] = point[(a + 2) % 3];
    }
    Schedule schedule;
    schedule.cut = TaskCut(nLeafRays);
    nParts_ = 0;
    for (uint32_t r = 0; r < g.roots; ++r) {
        if (g.rootBegin[r] == g.rootBegin[r + 1]) continue;
        const int face = int(r % kFaceCount);
        const FaceList& all = (*faceLists_)[face];
        Task task{};
        task.node = kNoNode;
        task.list = View(all, all.Size(), &listFrame_[face]);
        task.part = &NewPart(g.rootBegin[r]);
        task.cells = {r, 0, 0};
        schedule.queue.push_back(task);
    }
    const int workers = StartWorkers(schedule, nLeafRays, out);
    OnThreads(workers, [&](int t) { Work(workers_[size_t(t)], t); });
    Join(out, schedule.listsEnd.load(), workers);
    rayOut_ = nullptr;
    size_t scratch =
        (g.key.capacity() + g.begin.capacity()) * 4 + g.box.capacity() * sizeof(CellBox);
    for (size_t p = 0; p < g.count.size(); ++p)
        scratch += (g.count[p].capacity() + g.end[p].capacity()) * 4;
    FinishWorkers(scratch);
    return true;
}

bool Hierarchy::CellKeys(RayView rays, const CommonEnds& endsIn, uint32_t firstId, uint32_t* keys,
                         uint32_t* count, float* end, std::vector<rc_uint>& missed,
                         uint64_t& fromEndOut) const {
    // Locals: the pieces' counters of rays taken from an end share a cache line, and updating
    // them in place a block at a time made this pass 1.6x slower on two cores (4.1 against
    // 2.6 ms for Sibenik's shadow rays); the copied points need no reload after each store.
    const CommonEnds ends = endsIn;
    uint64_t fromEnd = 0;
    const int bits = cells_.bits;
    const float half = float(1u << bits) * 0.5f;
    const int top = (1 << bits) - 1;
    const size_t n = rays.size();
    size_t i = 0;
#if defined(RC_CELLS_AVX512)
    // Convert's fast path of ToRay5, operation for operation, on rays that all start at their
    // point, inside the box.
    const __m512i idx = RayOffsets16(rays);
    const bool packed = rays.Stride() == 8 * sizeof(float);
    const __m512 one = _mm512_set1_ps(1.0f);
    const __m512 halfV = _mm512_set1_ps(half);
    const __m512 blo[3] = {_mm512_set1_ps(sceneBox_.lo.x), _mm512_set1_ps(sceneBox_.lo.y),
                           _mm512_set1_ps(sceneBox_.lo.z)};
    const __m512 bhi[3] = {_mm512_set1_ps(sceneBox_.hi.x), _mm512_set1_ps(sceneBox_.hi.y),
                           _mm512_set1_ps(sceneBox_.hi.z)};
    const __mmask16 all = 0xFFFF;
    const __m512i zeroI = _mm512_setzero_si512(), oneI = _mm512_set1_epi32(1);
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    // Lane i: the mask of lanes 0 .. i.
    const __m512i lanesUpTo =
        _mm512_maskz_sub_epi32(all, _mm512_maskz_sllv_epi32(all, _mm512_set1_epi32(2), lane), oneI);
    const __m512i topI = _mm512_set1_epi32(top);
    auto spread = [&](__m512i x) {
        x = _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_slli_epi32(all, x, 4)),
                             _mm512_set1_epi32(0x0F0F));
        x = _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_slli_epi32(all, x, 2)),
                             _mm512_set1_epi32(0x3333));
        return _mm512_and_si512(_mm512_or_si512(x, _mm512_maskz_slli_epi32(all, x, 1)),
                                _mm512_set1_epi32(0x5555));
    };
    auto cell = [&](__m512 s) {
        const __m512i c =
            _mm512_maskz_cvt_roundps_epi32(all, _mm512_mul_ps(_mm512_add_ps(s, one), halfV),
                                           _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
        return _mm512_maskz_min_epi32(all, _mm512_maskz_max_epi32(all, c, zeroI), topI);
    };
    for (; i < n; i += 16) {
        const __mmask16 live = LiveLanes16(n, i);
        Rays16 r = packed ? Load16Packed(rays.Floats(i), std::min<size_t>(16, n - i))
                          : Gather16(rays.Floats(i), idx, live);
        __m512i which = zeroI;
        const __mmask16 matched = Orient16(ends, live, r, &which);
        for (unsigned other = unsigned(live & ~matched); other; other &= other - 1) {
            const size_t j = size_t(std::countr_zero(other));
            if (!Dead(rays[i + j])) return false;
            missed.push_back(firstId + uint32_t(i + j));
        }
        const auto [ox, oy, oz, tmin, dx, dy, dz, tmax] = r;
        const Axis16 axes = DominantAxis16(dx, dy, dz);
        const auto [isX, isY, isZ, neg, ax, ay, az, da] = axes;
        const __mmask16 fast =
            __mmask16(matched & InBox16(ox, oy, oz, blo, bhi) & Mappable16(axes, dx, dy, dz));
        if (matched & ~fast) return false;
        if (!fast) {
            _mm512_mask_storeu_epi32(keys + i, live, _mm512_set1_epi32(-1));
            continue;
        }
        // (tMin is 0 once oriented, so the start is the origin.)
        const __m512 origin[3] = {ox, oy, oz};
        const Point16 p = FacePoint16(origin, dx, dy, dz, tmin, tmax, axes, fast, blo, bhi);
        const __m512 u = p.u, v = p.v, e = p.end;
        // face = 2 axis + (d_a < 0); root = end * kFaceCount + face
        const __m512i axis = _mm512_mask_blend_epi32(isZ, _mm512_mask_blend_epi32(isY, zeroI, oneI),
                                                     _mm512_set1_epi32(2));
        const __m512i face = _mm512_mask_add_epi32(_mm512_add_epi32(axis, axis), neg,
                                                   _mm512_add_epi32(axis, axis), oneI);
        const __m512i root =
            _mm512_add_epi32(_mm512_mullo_epi32(which, _mm512_set1_epi32(kFaceCount)), face);
        const __m512i key = _mm512_or_si512(
            _mm512_maskz_slli_epi32(all, root, unsigned(2 * bits)),
            _mm512_or_si512(_mm512_maskz_slli_epi32(all, spread(cell(u)), 1), spread(cell(v))));
        // Rays that miss keep no key.
        const __m512i k = _mm512_mask_blend_epi32(fast, _mm512_set1_epi32(-1), key);
        _mm512_mask_storeu_epi32(keys + i, live, k);
        // The cells' counts and largest ends: neighbouring rays often share a cell (a run of
        // 3 on average on Sibenik's shadow rays at 128 cells a side), so each run of equal keys
        // in the block updates its cell once (its length, and the largest end found by a
        // segmented max over the run).
        const __m512i previous = _mm512_maskz_permutexvar_epi32(
            all, _mm512_maskz_sub_epi32(all, _mm512_maskz_max_epi32(all, lane, oneI), oneI), k);
        const __mmask16 starts = __mmask16(_mm512_cmpneq_epi32_mask(k, previous) | 1u);
        const __mmask16 runEnds = __mmask16(((starts >> 1) | 0x8000u) & fast);
        // Each lane's run starts at the last start at or below it.
        const __m512i below = _mm512_and_si512(_mm512_set1_epi32(starts), lanesUpTo);
        const __m512i runStart =
            _mm512_sub_epi32(_mm512_set1_epi32(31), _mm512_maskz_lzcnt_epi32(all, below));
        const __m512i runLength = _mm512_add_epi32(_mm512_sub_epi32(lane, runStart), oneI);
        __m512 runEnd = e;
        for (int step = 1; step < 16; step *= 2) {
            const __m512i from = _mm512_sub_epi32(lane, _mm512_set1_epi32(step));
            const __mmask16 inRun = _mm512_cmpge_epi32_mask(from, runStart);
            runEnd = _mm512_mask_max_ps(
                runEnd, inRun, runEnd,
                _mm512_maskz_permutexvar_ps(all, _mm512_maskz_max_epi32(all, from, zeroI), runEnd));
        }
        alignas(64) uint32_t runKey[16], runCount[16];
        alignas(64) float runMax[16];
        _mm512_store_si512(runKey, _mm512_maskz_compress_epi32(runEnds, k));
        _mm512_store_si512(runCount, _mm512_maskz_compress_epi32(runEnds, runLength));
        _mm512_store_ps(runMax, _mm512_maskz_compress_ps(runEnds, runEnd));
        for (int j = 0, runs = std::popcount(unsigned(runEnds)); j < runs; ++j) {
            float* at = end + runKey[j];
            count[runKey[j]] += runCount[j];
            // A max without a branch: a compare and jump around the store mispredicts.
            _mm_store_ss(at, _mm_max_ss(_mm_load_ss(at), _mm_load_ss(runMax + j)));
        }
        fromEnd += uint64_t(std::popcount(unsigned(fast)));
    }
#endif
    for (; i < n; ++i) {
        const Ray ray = rays[i];
        const int match = ends.Match(ray);
        if (match < 0) {
            if (!Dead(ray)) return false;
            keys[i] = kNoNode;
            missed.push_back(firstId + uint32_t(i));
            continue;
        }
        Ray5 r5;
        float e;
        if (!PointFromEnd(ends, match, ray, sceneBox_, r5, e)) return false;
        auto cellOf = [&](float s) {
            return uint32_t(std::clamp(int(std::floor((s + 1.0f) * half)), 0, top));
        };
        const uint32_t key = (uint32_t(match * kFaceCount + r5.face) << (2 * bits)) |
                             Spread(cellOf(r5.p[3])) << 1 | Spread(cellOf(r5.p[4]));
        keys[i] = key;
        ++count[key];
        end[key] = std::max(end[key], e);
        ++fromEnd;
    }
    fromEndOut = fromEnd;
    return true;
}

Bounds6 Hierarchy::CellBounds(const CellAt& at) const {
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

void Hierarchy::SpawnCells(Worker& w, const CellAt& at, const ListView& list, bool reuseList) {
    Schedule& s = *w.schedule;
    const uint32_t begin = cells_.rootBegin[at.root] +
                           cells_.begin[size_t(at.root) * ((size_t(1) << (2 * cells_.bits)) + 1) +
                                        (size_t(at.prefix) << (2 * cells_.bits - at.depth))];
    {
        std::lock_guard lock(s.mutex);
        Task task{};
        task.node = kNoNode;
        task.list = list;  // a kept list or the face's: both outlive the task
        task.reuseList = reuseList;
        task.part = &NewPart(begin);
        task.cells = at;
        s.queue.push_back(task);
    }
    s.changed.notify_one();
}

void Hierarchy::ProcessCells(Worker& w, CellAt at, const ListView& list, bool reuseList) {
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
    const bool spawns = nRays > w.schedule->cut;
    const bool filtered = !reuseList && !KeepsMost(tight, list);
    ListView own = filtered ? Filter(w, tight, list, spawns) : CutAtEnd(tight, list);
    Node node;
    node.box = tight.ToBox5();
    node.face = uint8_t(face);
    node.depth = uint8_t(at.depth);
    int dim = 0;
    // A single cell is split further only when its list is long (see kRefineCandidates).
    const bool split = at.depth < bits2 || own.n >= kRefineCandidates;
    if (split && ChooseSplit(node, tight, nRays, own, dim)) {
        if (at.depth == bits2) {
            RefineCell(w, at.root, begin, nRays, at.depth, own);
            return;
        }
        const bool reuse = filtered && (at.depth + 1) % std::max(params_.splitsPerList, 1) != 0;
        const CellAt left{at.root, 2 * at.prefix, at.depth + 1};
        const CellAt right{at.root, 2 * at.prefix + 1, at.depth + 1};
        // A node with many rays queues its right half, so that another thread can start on it.
        if (spawns) SpawnCells(w, right, own, reuse);
        ProcessCells(w, left, own, reuse);
        if (!spawns) ProcessCells(w, right, own, reuse);
        return;
    }
    if (!filtered) own = Filter(w, tight, list, false);
    RcLeaf leaf{};
    leaf.rayBegin = begin;
    leaf.rayCount = nRays;
    PushLeaf(w, leaf, NewNode(w, node.box, face, at.depth, false), own, tight.hi[kDims]);
}

void Hierarchy::RefineCell(Worker& w, uint32_t root, uint32_t begin, uint32_t n, int depth,
                           const ListView& list) {
    const CellGrid& g = cells_;
    std::vector<CellRay>& rays = w.cellRays;
    rays.resize(n);
    for (uint32_t j = 0; j < n; ++j) {
        // Mapped as CellKeys mapped it (which took every ray of a cell).
        const uint32_t id = rayOut_[begin + j];
        const Ray ray = g.rays[id];
        Ray5 p;
        float end = 0.0f;
        PointFromEnd(g.ends, g.ends.Match(ray), ray, sceneBox_, p, end);
        rays[j] = {p.p[3], p.p[4], end, id};
    }
    ProcessCellRays(w, root, rays.data(), n, begin, depth, list, true);
}

void Hierarchy::ProcessCellRays(Worker& w, uint32_t root, CellRay* rays, uint32_t n, uint32_t slot,
                                int depth, const ListView& list, bool reuseList) {
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
    ListView own = filtered ? Filter(w, tight, list, false) : CutAtEnd(tight, list);
    Node node;
    node.box = tight.ToBox5();
    node.face = uint8_t(face);
    node.depth = uint8_t(std::min(depth, 255));
    int dim = 0;
    if (ChooseSplit(node, tight, n, own, dim)) {
        const float value = Midpoint(tight.lo[dim], tight.hi[dim]);
        CellRay* mid = std::partition(
            rays, rays + n, [&](const CellRay& r) { return (dim == 3 ? r.u : r.v) < value; });
        const uint32_t left = uint32_t(mid - rays);
        if (left > 0 && left < n) {
            const bool reuse = filtered && (depth + 1) % std::max(params_.splitsPerList, 1) != 0;
            ProcessCellRays(w, root, rays, left, slot, depth + 1, own, reuse);
            ProcessCellRays(w, root, mid, n - left, slot + left, depth + 1, own, reuse);
            return;
        }
    }
    if (!filtered) own = Filter(w, tight, list, false);
    for (uint32_t j = 0; j < n; ++j) rayOut_[slot + j] = rays[j].id;
    RcLeaf leaf{};
    leaf.rayBegin = slot;
    leaf.rayCount = n;
    PushLeaf(w, leaf, NewNode(w, node.box, face, node.depth, false), own, tight.hi[kDims]);
}

}  // namespace rayclass::classify
