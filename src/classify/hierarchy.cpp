#include "rayclass/classify/hierarchy.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <barrier>
#include <bit>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <future>
#include <mutex>
#include <numeric>
#include <thread>

#include "filter.h"
#include "rayclass/core/radix_sort.h"

#if defined(__AVX512F__)
#include "avx512.h"
#endif

namespace rayclass::classify {

Box5 Bounds6::ToBox5() const {
    Box5 b;
    for (int k = 0; k < kDims; ++k) {
        b.lo[k] = lo[k];
        b.hi[k] = hi[k];
    }
    return b;
}

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr float kFloatMax = 3.402823466e38f;
constexpr int kCoords = kDims + 1;
// Scenes smaller than this sort their face lists on one thread: starting threads costs more.
constexpr uint32_t kParallelSortMin = 16384;
// Generations with fewer rays are subdivided on one thread, for the same reason.
constexpr uint32_t kParallelRaysMin = 32768;
// Plans for fewer rays move them on one thread.
constexpr uint32_t kParallelPlanRays = 131072;
// Batches with fewer candidates copy their leaves' lists on one thread.
constexpr size_t kParallelCopyMin = size_t(1) << 17;
// Nodes with more than max(kTaskRaysMin, rays / kTasks) rays hand their later children to the
// task queue: enough tasks to balance the threads, few enough that their kept lists cost little
// (Conference with mirror rays, batches of 2^18: render 1.29 s with a minimum of 4,096 rays,
// 1.22 s with 32,768, 1.18 s on one thread without tasks).
constexpr uint32_t kTaskRaysMin = 32768;
constexpr uint32_t kTasks = 32;
// Entries per chunk of a worker's list arenas (a longer list gets a chunk of its own).
constexpr size_t kListChunk = size_t(1) << 18;

// Runs f(t) for t in [0, n), f(0) on the calling thread.
template <typename F>
void OnThreads(int n, const F& f) {
    std::vector<std::future<void>> others;
    for (int t = 1; t < n; ++t) others.push_back(std::async(std::launch::async, [&f, t] { f(t); }));
    f(0);
    for (auto& o : others) o.get();
}

void MinMax(const float* x, size_t n, float& lo, float& hi) {
#if defined(__AVX512F__)
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
#else
    float l = kInf, h = -kInf;
    for (size_t i = 0; i < n; ++i) {
        l = std::min(l, x[i]);
        h = std::max(h, x[i]);
    }
    lo = l;
    hi = h;
#endif
}

// Where a partition reads and writes the rays of a node: one array per dimension, and the ids.
struct PartitionIo {
    const float* src[kCoords];
    float* dst[kCoords];
    const uint32_t* srcId;
    uint32_t* dstId;
    const float* key;
};

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

// Moves the rays with key < value to the front of [begin, end) of the destination (in order) and
// the others to the back (reversed), for the dimensions in kActive only, and gathers both sides'
// bounds on the way (the other dimensions' bounds are left to the caller). Returns the first
// right-side position. kActive is a template argument so that the per-dimension registers stay
// registers.
template <int kActive>
uint32_t PartitionRays(const PartitionIo& io, float value, uint32_t begin, uint32_t end,
                       Bounds6& leftBox, Bounds6& rightBox) {
    uint32_t l = begin, r = end;
#if defined(__AVX512F__)
    const __m512 m = _mm512_set1_ps(value);
    __m512 lLo[kCoords], lHi[kCoords], rLo[kCoords], rHi[kCoords];
    for (int k = 0; k < kCoords; ++k) {
        lLo[k] = rLo[k] = _mm512_set1_ps(kInf);
        lHi[k] = rHi[k] = _mm512_set1_ps(-kInf);
    }
    // Local copies: stores through the destination pointers could otherwise alias `io`, and the
    // compiler would reload every pointer after every store.
    const float* src[kCoords];
    float* dst[kCoords];
    for (int k = 0; k < kCoords; ++k) {
        src[k] = io.src[k];
        dst[k] = io.dst[k];
    }
    const float* const key = io.key;
    const uint32_t* const srcId = io.srcId;
    uint32_t* const dstId = io.dstId;
    for (uint32_t i = begin; i < end; i += 16) {
        const uint32_t rest = end - i;
        const __mmask16 live = rest >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << rest) - 1u);
        const __m512 kv = _mm512_maskz_loadu_ps(live, key + i);
        const __mmask16 left = _mm512_mask_cmp_ps_mask(live, kv, m, _CMP_LT_OQ);
        const __mmask16 right = __mmask16(live & ~left);
        const uint32_t nl = uint32_t(std::popcount(unsigned(left)));
        const uint32_t nr = uint32_t(std::popcount(unsigned(right)));
        const __mmask16 ml = __mmask16((1u << nl) - 1u), mr = __mmask16((1u << nr) - 1u);
#pragma GCC unroll 6
        for (int k = 0; k < kCoords; ++k) {
            if (!((kActive >> k) & 1)) continue;
            const __m512 v = _mm512_maskz_loadu_ps(live, src[k] + i);
            _mm512_mask_storeu_ps(dst[k] + l, ml, _mm512_maskz_compress_ps(left, v));
            _mm512_mask_storeu_ps(dst[k] + r - nr, mr, _mm512_maskz_compress_ps(right, v));
            lLo[k] = _mm512_mask_min_ps(lLo[k], left, lLo[k], v);
            lHi[k] = _mm512_mask_max_ps(lHi[k], left, lHi[k], v);
            rLo[k] = _mm512_mask_min_ps(rLo[k], right, rLo[k], v);
            rHi[k] = _mm512_mask_max_ps(rHi[k], right, rHi[k], v);
        }
        const __m512i id = _mm512_maskz_loadu_epi32(live, srcId + i);
        _mm512_mask_storeu_epi32(dstId + l, ml, _mm512_maskz_compress_epi32(left, id));
        _mm512_mask_storeu_epi32(dstId + r - nr, mr, _mm512_maskz_compress_epi32(right, id));
        l += nl;
        r -= nr;
    }
    for (int k = 0; k < kCoords; ++k) {
        if (!((kActive >> k) & 1)) continue;
        leftBox.lo[k] = ReduceMin(lLo[k]);
        leftBox.hi[k] = ReduceMax(lHi[k]);
        rightBox.lo[k] = ReduceMin(rLo[k]);
        rightBox.hi[k] = ReduceMax(rHi[k]);
    }
#else
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
#endif
    return l;
}

// Whether keys[begin, end) are already split at `value`: all keys below it first, or all keys
// below it last. Then *first is the length of the first run and *firstLeft whether it holds the
// keys below. Gives up at the second change of side, so an unordered range costs a block or
// two. Rays that arrive in an order matching the splits (eye rays in pixel order, whose rows
// are intervals of one slope) are then split without being moved.
bool AlreadySplit(const float* key, float value, uint32_t begin, uint32_t end, uint32_t* first,
                  bool* firstLeft) {
    uint32_t changes = 0, run = end - begin;
    int prev = -1;
#if defined(__AVX512F__)
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
#else
    for (uint32_t i = begin; i < end; ++i) {
        const int left = key[i] < value ? 1 : 0;
        if (prev < 0) *firstLeft = left;
        if (prev >= 0 && left != prev) {
            if (changes++ == 0) run = i - begin;
            if (changes > 1) return false;
        }
        prev = left;
    }
#endif
    *first = run;
    return true;
}

template <int kActive = 0>
uint32_t DispatchPartition(int active, const PartitionIo& io, float value, uint32_t begin,
                           uint32_t end, Bounds6& leftBox, Bounds6& rightBox) {
    if constexpr (kActive == 1 << kCoords) {
        return begin;
    } else {
        if (active == kActive) return PartitionRays<kActive>(io, value, begin, end, leftBox, rightBox);
        return DispatchPartition<kActive + 1>(active, io, value, begin, end, leftBox, rightBox);
    }
}

}  // namespace

namespace {
// Scratch is resized without keeping its contents: growing then copies nothing, so the
// uninitialised tail of the old buffer is never read. (Reading it maps the zero page, and writing
// that memory after malloc hands it out again costs a copy-on-write fault and a TLB shootdown
// on every core: Conference renders were 20 % slower for it.)
template <typename V>
void Regrow(V& v, size_t n) {
    if (n > v.capacity()) {
        // Geometric growth, as resize() would do: a list that grows a little at a time must not
        // be reallocated (and its pages faulted in again) every time.
        v.clear();
        v.reserve(std::max(n, 2 * v.capacity()));
    }
    v.resize(n);
}
}  // namespace

void Hierarchy::FaceList::Resize(size_t n) {
    for (auto* a : {&x0, &x1, &y0, &y1, &z0, &z1}) Regrow(*a, n);
    Regrow(prim, n);
}

Hierarchy::Hierarchy(const scene::Scene& scene, const Params& params)
    : scene_(scene), params_(params) {
    sceneBox_ = scene.Bounds();
    if (!sceneBox_.Empty()) {
        sceneBox_.lo -= glm::vec3(params_.padding);
        sceneBox_.hi += glm::vec3(params_.padding);
    }
    const uint32_t nPrims = scene.PrimitiveCount();
    std::vector<Bounds3f> boxes(nPrims);
    for (uint32_t id = 0; id < nPrims; ++id) {
        boxes[id] = scene.PrimitiveBounds(id);
        boxes[id].lo -= glm::vec3(params_.padding);
        boxes[id].hi += glm::vec3(params_.padding);
    }
    auto lists = std::make_shared<std::array<FaceList, kFaceCount>>();
    for (int face = 0; face < kFaceCount; ++face) {
        const Box5 root = BoxInFace(face, sceneBox_);
        Node n;
        n.box = root;
        n.face = uint8_t(face);
        nodes_.push_back(n);
        for (int k = 0; k < kDims; ++k) rootExtent_[face][k] = std::max(root.hi[k] - root.lo[k], 0.0f);
    }
    // The faces' lists are independent: built on every core.
    auto buildFace = [&](int face) {
        std::vector<float> nearX(nPrims);
        for (uint32_t id = 0; id < nPrims; ++id) nearX[id] = BoxInFace(face, boxes[id]).lo[0];
        // The distance order: near side along the face's main axis, ties by id for determinism.
        const std::vector<uint32_t> order = SortedOrder(nearX);
        FaceList& l = (*lists)[face];
        l.Resize(nPrims);
        for (uint32_t i = 0; i < nPrims; ++i) {
            const Box5 b = BoxInFace(face, boxes[order[i]]);
            l.x0[i] = b.lo[0];
            l.x1[i] = b.hi[0];
            l.y0[i] = b.lo[1];
            l.y1[i] = b.hi[1];
            l.z0[i] = b.lo[2];
            l.z1[i] = b.hi[2];
            l.prim[i] = order[i];
        }
    };
    const int threads = nPrims < kParallelSortMin
                            ? 1
                            : int(std::clamp(std::thread::hardware_concurrency(), 1u, 6u));
    OnThreads(threads, [&](int t) {
        for (int face = t; face < kFaceCount; face += threads) buildFace(face);
    });
    faceLists_ = std::move(lists);
}

void Hierarchy::Reset() {
    nodes_.resize(kFaceCount);
    for (Node& n : nodes_) {
        n.child[0] = n.child[1] = n.remainder = kNoNode;
    }
}

uint32_t Hierarchy::NewNode(Worker& w, const Box5& box, int face, int depth, bool isRemainder) {
    Node n;
    n.box = box;
    n.face = uint8_t(face);
    n.depth = uint8_t(depth);
    n.isRemainder = isRemainder ? 1 : 0;
    w.nodes.push_back(n);
    return kLocal | uint32_t(w.nodes.size() - 1 - w.part->nodeBegin);
}

int Hierarchy::Threads(uint32_t nRays) const {
    if (params_.threads > 0) return int(params_.threads);
    if (nRays < kParallelRaysMin) return 1;
    return int(std::clamp(std::thread::hardware_concurrency(), 1u, 64u));
}

void Hierarchy::Insert(RayView rays, RayUse use) {
    Inserted in{rays, {}};
    if (use == RayUse::kAnyHit && !sceneBox_.Empty()) {
        in.ends = FindCommonEnds(rays, sceneBox_, 0.25f * params_.padding);
    }
    inserted_.push_back(in);
    nInserted_ += uint32_t(rays.size());
}

namespace {

// The face of a ray's direction, or kFaceCount when the direction is zero or not finite (such a
// ray misses everything, whichever path ToRay5 takes). ToRay5 picks the same face for the rest.
inline int DirectionFace(const glm::vec3& d) {
    if (!std::isfinite(d.x) || !std::isfinite(d.y) || !std::isfinite(d.z)) return kFaceCount;
    const int a = DominantAxis(d);
    if (!(std::abs(d[a]) > 0.0f)) return kFaceCount;
    return 2 * a + (d[a] < 0.0f ? 1 : 0);
}

// b grows to contain `other`.
void Merge(Bounds6& b, const Bounds6& other) {
    for (int k = 0; k < kCoords; ++k) {
        b.lo[k] = std::min(b.lo[k], other.lo[k]);
        b.hi[k] = std::max(b.hi[k], other.hi[k]);
    }
}

void GrowBounds(Bounds6& b, const float* p) {
    for (int k = 0; k < kCoords; ++k) {
        b.lo[k] = std::min(b.lo[k], p[k]);
        b.hi[k] = std::max(b.hi[k], p[k]);
    }
}

Bounds6 EmptyBounds() {
    Bounds6 b;
    for (int k = 0; k < kCoords; ++k) {
        b.lo[k] = kInf;
        b.hi[k] = -kInf;
    }
    return b;
}

#if defined(__AVX512F__)
// Gather offsets (in floats) of 16 consecutive rays of `rays` from the first.
__m512i RayOffsets16(const RayView& rays) {
    return _mm512_mullo_epi32(
        _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15),
        _mm512_set1_epi32(int(rays.Stride() / 4)));
}

// The lanes of the 16 rays from i on that exist among n.
__mmask16 LiveLanes16(size_t n, size_t i) {
    const size_t rest = n - i;
    return rest >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << rest) - 1u);
}

// DominantAxis of 16 directions (ties to the lower axis): a mask per axis, the direction's
// absolute components, |d_a| and whether d_a < 0.
struct Axis16 {
    __mmask16 isX, isY, isZ, neg;
    __m512 ax, ay, az, da;
};

Axis16 DominantAxis16(__m512 dx, __m512 dy, __m512 dz) {
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

// 16 rays' fields, gathered from a RayView.
struct Rays16 {
    __m512 ox, oy, oz, tmin, dx, dy, dz, tmax;
};

Rays16 Gather16(const float* at, __m512i idx, __mmask16 live) {
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

// CommonEnds::Oriented for the live lanes of r, with the same float operations, so both paths
// take a ray alike. Returns the lanes taken from an end.
__mmask16 Orient16(const CommonEnds& ends, __mmask16 live, Rays16& r) {
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
    auto near = [&](__m512 e, float p) {
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

#endif

}  // namespace

uint64_t Hierarchy::Convert(RayView rays, const CommonEnds& ends, uint32_t firstId, uint32_t* next,
                            Bounds6* faceBounds, std::vector<rc_uint>& missed) {
    uint64_t fromEnd = 0;
    float* c[kCoords];
    for (int k = 0; k < kCoords; ++k) c[k] = coord_[0][k].data();
    uint32_t* ids = id_[0].data();
    // Where each face's X leaves the scene box: ends beyond it are cut there, so the rays that
    // leave the box share one end, which then stays a constant that partitions do not move.
    float faceEnd[kFaceCount];
    for (int f = 0; f < kFaceCount; ++f) faceEnd[f] = BoxInFace(f, sceneBox_).hi[0];
    // A ray that ToRay5 maps: written at its face's next position.
    auto put = [&](const Ray5& r, uint32_t id) {
        const uint32_t at = next[r.face]++;
        const float p[kCoords] = {r.p[0], r.p[1], r.p[2], r.p[3], r.p[4],
                                  std::min(r.p[0] + r.reach, faceEnd[r.face])};
        for (int k = 0; k < kCoords; ++k) c[k][at] = p[k];
        ids[at] = id;
        GrowBounds(faceBounds[r.face], p);
    };
    const size_t n = rays.size();
    size_t i = 0;
#if defined(__AVX512F__)
    // The fast path of ToRay5 for 16 rays at a time, with the same float operations so the points
    // are bit-identical; lanes that need the slow path take the scalar one.
    const __m512i idx = RayOffsets16(rays);
    const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
    const __m512 absMask = _mm512_castsi512_ps(_mm512_set1_epi32(0x7FFFFFFF));
    const __m512 signMask = _mm512_castsi512_ps(_mm512_set1_epi32(int(0x80000000u)));
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
        Rays16 r = Gather16(rays.Floats(i), idx, live);
        fromEnd += uint64_t(std::popcount(unsigned(Orient16(ends, live, r))));
        const auto [ox, oy, oz, tmin, dx, dy, dz, tmax] = r;
        const auto [isX, isY, isZ, neg, ax, ay, az, da] = DominantAxis16(dx, dy, dz);
        // start = tMin == 0 ? origin : origin + tMin d
        const __mmask16 t0 = _mm512_cmp_ps_mask(tmin, zero, _CMP_EQ_OQ);
        const __m512 sx = _mm512_mask_blend_ps(t0, _mm512_add_ps(ox, _mm512_mul_ps(tmin, dx)), ox);
        const __m512 sy = _mm512_mask_blend_ps(t0, _mm512_add_ps(oy, _mm512_mul_ps(tmin, dy)), oy);
        const __m512 sz = _mm512_mask_blend_ps(t0, _mm512_add_ps(oz, _mm512_mul_ps(tmin, dz)), oz);
        const __mmask16 inside =
            _mm512_cmp_ps_mask(sx, blo[0], _CMP_GE_OQ) & _mm512_cmp_ps_mask(sx, bhi[0], _CMP_LE_OQ) &
            _mm512_cmp_ps_mask(sy, blo[1], _CMP_GE_OQ) & _mm512_cmp_ps_mask(sy, bhi[1], _CMP_LE_OQ) &
            _mm512_cmp_ps_mask(sz, blo[2], _CMP_GE_OQ) & _mm512_cmp_ps_mask(sz, bhi[2], _CMP_LE_OQ);
        const __m512 dsum = _mm512_add_ps(_mm512_add_ps(dx, dy), dz);
        const __mmask16 fast =
            __mmask16(live & inside & _mm512_cmp_ps_mask(da, zero, _CMP_GT_OQ) &
                      _mm512_cmp_ps_mask(_mm512_and_ps(dsum, absMask), fmax, _CMP_LE_OQ) &
                      _mm512_cmp_ps_mask(tmin, tmax, _CMP_LT_OQ));
        // Frame: X = s p_a, Y = p_b, Z = p_c with b = a + 1, c = a + 2 (mod 3).
        const __m512 pa = _mm512_mask_blend_ps(isX, _mm512_mask_blend_ps(isY, sz, sy), sx);
        const __m512 x = _mm512_mask_xor_ps(pa, neg, pa, signMask);
        const __m512 y = _mm512_mask_blend_ps(isX, _mm512_mask_blend_ps(isY, sx, sz), sy);
        const __m512 z = _mm512_mask_blend_ps(isX, _mm512_mask_blend_ps(isY, sy, sx), sz);
        const __m512 db = _mm512_mask_blend_ps(isX, _mm512_mask_blend_ps(isY, dx, dz), dy);
        const __m512 dc = _mm512_mask_blend_ps(isX, _mm512_mask_blend_ps(isY, dy, dx), dz);
        const __m512 inv = _mm512_div_ps(one, _mm512_mask_blend_ps(fast, one, da));
        const __m512 u = _mm512_mul_ps(db, inv);
        const __m512 v = _mm512_mul_ps(dc, inv);
        const __m512 reach = Min16(_mm512_mul_ps(_mm512_sub_ps(tmax, tmin), da), fmax);
        const __m512 hiA = _mm512_mask_blend_ps(isX, _mm512_mask_blend_ps(isY, bhi[2], bhi[1]), bhi[0]);
        const __m512 loA = _mm512_mask_blend_ps(isX, _mm512_mask_blend_ps(isY, blo[2], blo[1]), blo[0]);
        const __m512 xEnd = _mm512_mask_xor_ps(hiA, neg, loA, signMask);  // BoxInFace's hi X
        const __m512 end = Min16(_mm512_add_ps(x, reach), xEnd);
        const __m512 p[kCoords] = {x, y, z, u, v, end};
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
            for (int k = 0; k < kCoords; ++k) {
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
            p.fromEnd = Convert(p.rays, *p.ends, p.firstId, p.next, p.bounds, p.missed);
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
                    move(coord_[0][k].data());
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
    std::sort(out.missed.begin(), out.missed.end());
}

struct Hierarchy::Schedule {
    std::mutex mutex;
    std::condition_variable changed;
    std::deque<Task> queue;
    int threads = 1;
    int busy = 0;  // threads inside a task
    uint32_t cut;  // nodes with more rays hand their later children to the queue
};

void Hierarchy::Subdivide(LeafBatch& out) {
    counters_ = {};
    // rayIndex and candidates are resized, not cleared: every slot is written again, and
    // filling them with zeros first would cost a pass on one thread.
    out.leaves.clear();
    out.missed.clear();
    out.nRays = nInserted_;
    uint32_t begin[kFaceCount], end[kFaceCount];
    Bounds6 faceBounds[kFaceCount];
    ConvertAll(begin, end, faceBounds, out);
    uint32_t n = 0;
    for (int f = 0; f < kFaceCount; ++f) {
        rayShift_[f] = n - begin[f];
        n += end[f] - begin[f];
    }
    out.rayIndex.resize(n);
    rayOut_ = out.rayIndex.data();
    // Coordinates that do not vary among a face's rays (the origin of eye rays, the end of
    // unbounded rays) are never moved.
    for (int f = 0; f < kFaceCount; ++f) {
        for (int k = 0; k < kCoords; ++k) {
            active_[f][k] = faceBounds[f].lo[k] < faceBounds[f].hi[k];
            constant_[f][k] = faceBounds[f].lo[k];
        }
    }
    Schedule schedule;
    schedule.cut = params_.taskRays > 0 ? params_.taskRays : std::max(kTaskRaysMin, n / kTasks);
    nParts_ = 0;
    for (int f = 0; f < kFaceCount; ++f) {
        if (begin[f] == end[f]) continue;
        const FaceList& all = (*faceLists_)[f];
        schedule.queue.push_back({FaceRoot(f), begin[f], end[f], 0, faceBounds[f],
                                  View(all, all.Size()), false, PlanAt(), &NewPart(begin[f])});
    }
    const int threads = Threads(n);
    schedule.threads = threads;
    if (workers_.size() < size_t(threads)) workers_.resize(size_t(threads));
    for (Worker& w : workers_) {
        w.counters = {};
        w.schedule = &schedule;
        w.leaves.clear();
        w.candidates.clear();
        w.nodes.clear();
        w.kept.chunk = w.kept.used = w.stack.chunk = w.stack.used = 0;
        w.plans.clear();
    }
    OnThreads(threads, [&](int t) { Work(workers_[size_t(t)], t); });
    Join(out);
    rayOut_ = nullptr;
    // The ray buffers by the rays they hold (two ping-pong buffers and the routing
    // destinations): their face slabs reserve kFaceCount times as much address space, of which
    // only the pages rays are written to are touched.
    size_t scratch = size_t(n) * (2 * (kCoords + 1) + 1) * 4;
    for (Worker& w : workers_) {
        counters_.boxTests += w.counters.boxTests;
        counters_.rayMoves += w.counters.rayMoves;
        counters_.plans += w.counters.plans;
        counters_.sharedPlans += w.counters.sharedPlans;
        counters_.maxDepth = std::max(counters_.maxDepth, w.counters.maxDepth);
        scratch += w.keys.capacity() * 4 + w.leaves.capacity() * sizeof(RcLeaf) +
                   w.candidates.capacity() * sizeof(RcCandidate) +
                   w.nodes.capacity() * sizeof(Node);
        for (const auto* a : {&w.stack, &w.kept}) {
            for (const auto& l : a->chunks) scratch += l.Bytes();
        }
        w.schedule = nullptr;
        w.part = nullptr;
    }
    counters_.scratchBytes = scratch;
    inserted_.clear();
    nInserted_ = 0;
}

void Hierarchy::Work(Worker& w, int index) {
    Schedule& s = *w.schedule;
    for (;;) {
        Task task;
        {
            std::unique_lock lock(s.mutex);
            s.changed.wait(lock, [&] { return !s.queue.empty() || s.busy == 0; });
            if (s.queue.empty()) return;
            task = s.queue.front();
            s.queue.pop_front();
            ++s.busy;
        }
        Part& part = *task.part;
        w.part = &part;
        part.worker = index;
        part.leafBegin = w.leaves.size();
        part.nodeBegin = w.nodes.size();
        if (part.newRoot) w.nodes.push_back(part.root);  // local id kLocal | 0
        Process(w, task.node, task.begin, task.end, task.buf, task.tight, task.list, task.reuseList,
                task.plan);
        part.leafEnd = w.leaves.size();
        part.nodeEnd = w.nodes.size();
        std::lock_guard lock(s.mutex);
        if (--s.busy == 0 && s.queue.empty()) s.changed.notify_all();
    }
}

namespace {
uint32_t& Link(Node& n, int field) { return field < 2 ? n.child[field] : n.remainder; }
}  // namespace

Hierarchy::Part& Hierarchy::NewPart(uint32_t begin) {
    if (nParts_ == parts_.size()) parts_.emplace_back();
    Part& p = parts_[nParts_++];
    p.begin = begin;
    p.relinked.clear();
    p.newRoot = false;
    p.linkPart = nullptr;
    p.linkNode = kNoNode;
    return p;
}

void Hierarchy::Spawn(Worker& w, uint32_t node, int field, const Box5* newBox, uint32_t begin,
                      uint32_t end, int buf, const Bounds6& tight, const ListView& list,
                      bool reuseList, PlanAt plan) {
    Schedule& s = *w.schedule;
    {
        std::lock_guard lock(s.mutex);
        Part& part = NewPart(begin);
        Node& parent = At(w, node);
        uint32_t root = Link(parent, field);
        if (newBox) {
            // The new root goes into the task's part, so that the task reads it as its own;
            // Join links the parent to it.
            Node n;
            n.box = *newBox;
            n.face = parent.face;
            n.depth = uint8_t(parent.depth + 1);
            n.isRemainder = field == 2 ? 1 : 0;
            part.newRoot = true;
            part.root = n;
            part.linkPart = w.part;
            part.linkNode = node;
            part.linkField = field;
            root = kLocal;
            Link(parent, field) = kPending;
        }
        // `list` views a kept list or the face's list: both outlive the task.
        // So does a plan: workers keep theirs until the next Subdivide.
        s.queue.push_back({root, begin, end, buf, tight, list, reuseList, plan, &part});
    }
    s.changed.notify_one();
}

void Hierarchy::Join(LeafBatch& out) {
    // Parts in ray order, their nodes appended in that order.
    std::vector<Part*> parts(nParts_);
    for (size_t p = 0; p < nParts_; ++p) parts[p] = &parts_[p];
    std::sort(parts.begin(), parts.end(),
              [](const Part* a, const Part* b) { return a->begin < b->begin; });
    uint32_t base = uint32_t(nodes_.size());
    for (Part* part : parts) {
        part->base = base;
        base += uint32_t(part->nodeEnd - part->nodeBegin);
    }
    struct Placed {
        RcLeaf leaf;
        const RcCandidate* candidates;
    };
    std::vector<Placed> leaves;
    size_t nCandidates = 0;
    for (Part* part : parts) {
        auto fix = [b = part->base](uint32_t& id) {
            if ((id & kLocal) && id < kPending) id = b + (id & ~kLocal);
        };
        Worker& w = workers_[size_t(part->worker)];
        for (size_t i = part->nodeBegin; i < part->nodeEnd; ++i) {
            Node& node = w.nodes[i];
            fix(node.child[0]);
            fix(node.child[1]);
            fix(node.remainder);
        }
        for (uint32_t g : part->relinked) {
            fix(nodes_[g].child[0]);
            fix(nodes_[g].child[1]);
            fix(nodes_[g].remainder);
        }
        for (size_t i = part->leafBegin; i < part->leafEnd; ++i) {
            RcLeaf leaf = w.leaves[i];
            fix(leaf.node);
            leaves.push_back({leaf, w.candidates.data() + leaf.candBegin});
            nCandidates += leaf.candCount;
        }
    }
    for (Part* part : parts) {
        const Worker& w = workers_[size_t(part->worker)];
        nodes_.insert(nodes_.end(), w.nodes.begin() + ptrdiff_t(part->nodeBegin),
                      w.nodes.begin() + ptrdiff_t(part->nodeEnd));
    }
    for (Part* part : parts) {
        if (part->linkNode == kNoNode) continue;
        const uint32_t parent = (part->linkNode & kLocal)
                                    ? part->linkPart->base + (part->linkNode & ~kLocal)
                                    : part->linkNode;
        Link(nodes_[parent], part->linkField) = part->base;
    }
    // Leaves in ray order (their ranges are disjoint and cover rayIndex), lists in leaf order.
    std::sort(leaves.begin(), leaves.end(),
              [](const Placed& a, const Placed& b) { return a.leaf.rayBegin < b.leaf.rayBegin; });
    out.leaves.resize(leaves.size());
    out.candidates.resize(nCandidates);
    uint32_t at = 0;
    for (size_t i = 0; i < leaves.size(); ++i) {
        out.leaves[i] = leaves[i].leaf;
        out.leaves[i].candBegin = at;
        at += leaves[i].leaf.candCount;
    }
    // The lists' copy, split between the threads at a leaf near the middle of the candidates.
    const int threads = nCandidates >= kParallelCopyMin ? Threads(nInserted_) : 1;
    std::vector<size_t> from(size_t(threads) + 1, leaves.size());
    from[0] = 0;
    for (int t = 1; t < threads; ++t) {
        const uint32_t want = uint32_t(nCandidates * size_t(t) / size_t(threads));
        from[size_t(t)] =
            size_t(std::partition_point(out.leaves.begin(), out.leaves.end(),
                                        [&](const RcLeaf& l) { return l.candBegin < want; }) -
                   out.leaves.begin());
    }
    OnThreads(threads, [&](int t) {
        for (size_t i = from[size_t(t)]; i < from[size_t(t) + 1]; ++i) {
            std::copy_n(leaves[i].candidates, out.leaves[i].candCount,
                        out.candidates.begin() + out.leaves[i].candBegin);
        }
    });
}

Bounds6 Hierarchy::Bounds(int face, int buf, uint32_t begin, uint32_t end) const {
    Bounds6 b;
    for (int k = 0; k < kCoords; ++k) {
        if (active_[face][k]) MinMax(coord_[buf][k].data() + begin, end - begin, b.lo[k], b.hi[k]);
    }
    SetConstants(face, b);
    return b;
}

void Hierarchy::SetConstants(int face, Bounds6& b) const {
    for (int k = 0; k < kCoords; ++k) {
        if (!active_[face][k]) b.lo[k] = b.hi[k] = constant_[face][k];
    }
}

namespace {

constexpr size_t kSampledFilterMin = 4096;  // lists shorter than this are always filtered
constexpr float kSkipKeep = 0.8f;           // skip the filter when it would keep more
constexpr size_t kSamples = 64;             // boxes tested for the estimate

// The list up to the node's end (see Filter).
ListView CutAtEnd(const Bounds6& tight, const ListView& list) {
    ListView in = list;
    in.n = size_t(std::upper_bound(in.x0, in.x0 + in.n, tight.hi[kDims]) - in.x0);
    return in;
}

// The fraction of kSamples evenly spaced boxes of the list (cut at the end) that the beam keeps.
float SampledKeepFraction(const Bounds6& tight, const ListView& list) {
    const ListView in = CutAtEnd(tight, list);
    if (in.n < kSampledFilterMin) return 0.0f;
    const BeamTest t = MakeBeamTest(tight.ToBox5(), tight.hi[kDims] - tight.lo[0]);
    size_t kept = 0, tested = 0;
    const size_t stride = in.n / kSamples;
    for (size_t i = stride / 2; i < in.n; i += stride) {
        kept += BeamMayReach(t, in.x0[i], in.x1[i], in.y0[i], in.y1[i], in.z0[i], in.z1[i]) ? 1 : 0;
        ++tested;
    }
    return float(kept) / float(tested);
}

// Whether the beam of `tight` would keep most of a long list (on a sample of it).
bool KeepsMost(const Bounds6& tight, const ListView& list) {
    return list.n >= kSampledFilterMin && SampledKeepFraction(tight, list) > kSkipKeep;
}

}  // namespace

namespace {

// Room for n entries at the end of `arena`: in its current chunk, else in the next one.
ListOut Take(Hierarchy::ListArena& arena, size_t n) {
    if (arena.chunk < arena.chunks.size() && arena.used + n > arena.chunks[arena.chunk].Size()) {
        ++arena.chunk;
        arena.used = 0;
    }
    if (arena.chunk == arena.chunks.size()) arena.chunks.emplace_back();
    Hierarchy::FaceList& c = arena.chunks[arena.chunk];
    // Only an empty chunk is too small here, and nothing points into an empty chunk.
    if (c.Size() < arena.used + n) c.Resize(std::max(n, kListChunk));
    return Out(c, arena.used);
}

}  // namespace

ListView Hierarchy::Filter(Worker& w, const Bounds6& tight, const ListView& list, bool keep) {
    // No ray of the node gets past X = end, and the list is sorted by near X: cut it there first.
    const float endHi = tight.hi[kDims];
    ListView in = list;
    in.n = size_t(std::upper_bound(in.x0, in.x0 + in.n, endHi) - in.x0);
    ListArena& arena = keep ? w.kept : w.stack;
    const ListOut out = Take(arena, in.n);
    // Every ray's reach is its end minus its start X, so the node's is at most endHi - lo X.
    const float reach = endHi - tight.lo[0];
    const size_t kept = FilterList(MakeBeamTest(tight.ToBox5(), reach), in, out);
    w.counters.boxTests += in.n;
    arena.used += kept;
    return {out.x0, out.x1, out.y0, out.y1, out.z0, out.z1, out.prim, kept};
}

void Hierarchy::RouteRays(int face, const Box5& box0, const Box5& box1, int buf, uint32_t begin,
                          uint32_t end, uint32_t count[3]) {
    const bool* active = active_[face];
    const float* constant = constant_[face];
    const int other = buf ^ 1;
    const float* src[kCoords];
    float* dst[kCoords];
    for (int k = 0; k < kCoords; ++k) {
        src[k] = coord_[buf][k].data();
        dst[k] = coord_[other][k].data();
    }
    const uint32_t* srcId = id_[buf].data();
    uint32_t* dstId = id_[other].data();
#if defined(__AVX512F__)
    // Pass 1: each block of 16 rays' groups as two masks, kept in dest_ at the block's first
    // position (positions are the task's own, so threads do not share them).
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
            const __m512 v = _mm512_maskz_loadu_ps(live, src[k] + i);
            c0 = _mm512_mask_cmp_ps_mask(c0, v, _mm512_set1_ps(box0.lo[k]), _CMP_GE_OQ);
            c0 = _mm512_mask_cmp_ps_mask(c0, v, _mm512_set1_ps(box0.hi[k]), _CMP_LE_OQ);
            c1 = _mm512_mask_cmp_ps_mask(c1, v, _mm512_set1_ps(box1.lo[k]), _CMP_GE_OQ);
            c1 = _mm512_mask_cmp_ps_mask(c1, v, _mm512_set1_ps(box1.hi[k]), _CMP_LE_OQ);
        }
        c1 = __mmask16(c1 & ~c0);
        count[0] += uint32_t(std::popcount(unsigned(c0)));
        count[1] += uint32_t(std::popcount(unsigned(c1)));
        count[2] += uint32_t(std::popcount(unsigned(live & ~c0 & ~c1)));
        dest_[i] = uint32_t(c0) | uint32_t(c1) << 16;
    }
    // Pass 2: every group in ray order after the groups before it.
    uint32_t next[3] = {begin, begin + count[0], begin + count[0] + count[1]};
    for (uint32_t i = begin; i < end; i += 16) {
        const __mmask16 live = LiveLanes16(end, i);
        const __mmask16 group[3] = {__mmask16(dest_[i]), __mmask16(dest_[i] >> 16),
                                    __mmask16(live & ~(dest_[i] | dest_[i] >> 16))};
        for (int k = 0; k < kCoords; ++k) {
            if (!active[k]) continue;
            const __m512 v = _mm512_maskz_loadu_ps(live, src[k] + i);
            for (int g = 0; g < 3; ++g) {
                if (!group[g]) continue;
                const uint32_t n = uint32_t(std::popcount(unsigned(group[g])));
                _mm512_mask_storeu_ps(dst[k] + next[g], __mmask16((1u << n) - 1u),
                                      _mm512_maskz_compress_ps(group[g], v));
            }
        }
        const __m512i id = _mm512_maskz_loadu_epi32(live, srcId + i);
        for (int g = 0; g < 3; ++g) {
            if (!group[g]) continue;
            const uint32_t n = uint32_t(std::popcount(unsigned(group[g])));
            _mm512_mask_storeu_epi32(dstId + next[g], __mmask16((1u << n) - 1u),
                                     _mm512_maskz_compress_epi32(group[g], id));
            next[g] += n;
        }
    }
#else
    for (uint32_t i = begin; i < end; ++i) {
        std::array<float, kDims> p;
        for (int k = 0; k < kDims; ++k) p[k] = active[k] ? src[k][i] : constant[k];
        const uint32_t g = box0.Contains(p) ? 0 : (box1.Contains(p) ? 1 : 2);
        dest_[i] = g;
        ++count[g];
    }
    uint32_t next[3] = {begin, begin + count[0], begin + count[0] + count[1]};
    for (uint32_t i = begin; i < end; ++i) dest_[i] = next[dest_[i]]++;
    for (int k = 0; k < kCoords; ++k) {
        if (!active[k]) continue;
        for (uint32_t i = begin; i < end; ++i) dst[k][dest_[i]] = src[k][i];
    }
    for (uint32_t i = begin; i < end; ++i) dstId[dest_[i]] = srcId[i];
#endif
}

void Hierarchy::Process(Worker& w, uint32_t node, uint32_t begin, uint32_t end, int buf,
                        const Bounds6& tight, const ListView& list, bool reuseList, PlanAt plan) {
    const int depth = At(w, node).depth;
    const int face = At(w, node).face;
    const int other = buf ^ 1;
    // The lists this node filters onto the stack are released when its subtree is built.
    struct Release {
        ListArena& arena;
        const size_t chunk, used;
        ~Release() {
            arena.chunk = chunk;
            arena.used = used;
        }
    } release{w.stack, w.stack.chunk, w.stack.used};
    // A node with many rays builds its first child and queues the others.
    const bool spawns = end - begin > w.schedule->cut;
    if (!At(w, node).IsLeaf()) {
        // A node split by an earlier generation: route by containment, the rest to the remainder.
        // Its list is filtered as a leaf's would be: not when the beam keeps most of it.
        const ListView own =
            KeepsMost(tight, list) ? CutAtEnd(tight, list) : Filter(w, tight, list, spawns);
        const Box5 box0 = At(w, At(w, node).child[0]).box;
        const Box5 box1 = At(w, At(w, node).child[1]).box;
        uint32_t count[3] = {};
        RouteRays(face, box0, box1, buf, begin, end, count);
        const uint32_t start[3] = {begin, begin + count[0], begin + count[0] + count[1]};
        w.counters.rayMoves += end - begin;
        // The later groups first, so that the queue gets them at once.
        const int firstGroup = count[0] ? 0 : (count[1] ? 1 : 2);
        for (int g = 2; g >= 0; --g) {
            if (count[g] == 0) continue;
            const uint32_t b = start[g], e = start[g] + count[g];
            const bool create = g == 2 && At(w, node).remainder == kNoNode;
            if (spawns && g != firstGroup) {
                const Box5 box = At(w, node).box;
                Spawn(w, node, g, create ? &box : nullptr, b, e, other, Bounds(face, other, b, e),
                      own, false, {});
                continue;
            }
            if (create) {
                const uint32_t r = NewNode(w, At(w, node).box, face, depth + 1, true);
                At(w, node).remainder = r;
                if (!(node & kLocal)) w.part->relinked.push_back(node);
            }
            Process(w, Link(At(w, node), g), b, e, other, Bounds(face, other, b, e), own, false,
                    {});
        }
        return;
    }

    // A long list that the node's beam would barely shorten (estimated on a sample) is not
    // copied: the children filter it instead. Near the roots of wide generations (mirror rays)
    // filters keep almost everything, and copying lists of 100k+ boxes is what costs there.
    const bool filtered = !reuseList && !KeepsMost(tight, list);
    ListView own = filtered ? Filter(w, tight, list, spawns) : CutAtEnd(tight, list);
    int dim = 0;
    Split split{begin, buf, true};
    Bounds6 childBox[2];  // left, right
    PlanAt childAt[2];
    if (ChooseSplit(At(w, node), tight, end - begin, own, dim)) {
        if (!plan.plan && params_.planRays > 0 && end - begin >= params_.planRays &&
            params_.splitRule == SplitRule::kMidpoint) {
            const Plan& made = MakePlan(w, face, dim, buf, begin, end, tight);
            plan = {&made, 0, 0, 1 << made.levels};
        }
        if (plan.plan && PlannedSplit(plan, begin, end, split.mid, childBox, childAt)) {
            split.buf = plan.plan->buf;
        } else {
            childAt[0] = childAt[1] = {};
            const float value = SplitValue(w, dim, buf, begin, end, tight);
            split = Partition(w, face, dim, value, buf, begin, end, childBox[0], childBox[1]);
        }
    }
    const uint32_t mid = split.mid;
    if (mid == begin || mid == end) {
        if (!filtered) own = Filter(w, tight, list, false);
        EmitLeaf(w, node, begin, end, buf, own, tight.hi[kDims]);
        return;
    }
    // near: the child whose rays come first, in [begin, mid); the other one's are [mid, end).
    const int near = split.leftFirst ? 0 : 1;
    const bool reuse = filtered && (depth + 1) % std::max(params_.splitsPerList, 1) != 0;
    if (spawns) {
        const uint32_t id = NewNode(w, childBox[near].ToBox5(), face, depth + 1, false);
        At(w, node).child[near] = id;
        if (!(node & kLocal)) w.part->relinked.push_back(node);
        // Queued first, so that another thread can start on it at once.
        const Box5 box = childBox[1 - near].ToBox5();
        Spawn(w, node, 1 - near, &box, mid, end, split.buf, childBox[1 - near], own, reuse,
              childAt[1 - near]);
        Process(w, id, begin, mid, split.buf, childBox[near], own, reuse, childAt[near]);
        return;
    }
    const uint32_t left = NewNode(w, childBox[0].ToBox5(), face, depth + 1, false);
    At(w, node).child[0] = left;
    if (!(node & kLocal)) w.part->relinked.push_back(node);
    const uint32_t right = NewNode(w, childBox[1].ToBox5(), face, depth + 1, false);
    At(w, node).child[1] = right;
    const uint32_t ids[2] = {left, right};
    Process(w, ids[near], begin, mid, split.buf, childBox[near], own, reuse, childAt[near]);
    Process(w, ids[1 - near], mid, end, split.buf, childBox[1 - near], own, reuse,
            childAt[1 - near]);
}

bool Hierarchy::ChooseSplit(const Node& node, const Bounds6& tight, uint32_t nRays,
                            const ListView& list, int& dim) const {
    const Params& p = params_;
    if (nRays < 2 || list.n <= p.minCandidates || node.depth >= p.maxDepth) return false;
    float extent[kDims];
    for (int k = 0; k < kDims; ++k) extent[k] = tight.hi[k] - tight.lo[k];
    dim = SplitDim(node.face, extent);
    if (dim < 0) return false;
    double listCost = 0.0;
    if (scene_.spheres.empty() && scene_.quadrics.empty()) {
        listCost = double(list.n) * p.triangleCost;
    } else {
        const uint32_t sphereBase = scene_.SphereBase(), quadricBase = scene_.QuadricBase();
        for (size_t i = 0; i < list.n; ++i) {
            const uint32_t id = list.prim[i];
            listCost += id < sphereBase ? p.triangleCost
                                        : (id < quadricBase ? p.sphereCost : p.quadricCost);
        }
    }
    const double saved = double(nRays) * listCost * p.splitGain;
    double cost = 2.0 * double(list.n) * p.boxTestCost + double(nRays) * p.rayMoveCost;
    // Below minRays the split also pays for the leaf it adds: the device runs each leaf as a
    // work-group, and one that is not full still costs about what a full one's first candidate
    // block does. So small groups split only for long lists, as long as the cost function says.
    if (nRays <= p.minRays) cost += double(p.minRays) * 16.0 * p.triangleCost;
    return saved > cost;
}

int Hierarchy::SplitDim(int face, const float* extent) const {
    const Params& p = params_;
    float best = 0.0f;
    int dim = -1;
    for (int k = 0; k < kDims; ++k) {
        const float root = rootExtent_[face][k];
        const bool isDir = k >= 3;
        const float minExtent = root * (isDir ? p.minDirFraction : p.minOriginFraction);
        if (!(extent[k] > minExtent)) continue;
        const float rel = extent[k] / root * (isDir ? p.dirWeight : 1.0f);
        if (rel > best) {
            best = rel;
            dim = k;
        }
    }
    return dim;
}

namespace {
// The midpoint split of [lo, hi]. When lo and hi are adjacent floats the middle rounds onto lo;
// hi still splits them.
float Midpoint(float lo, float hi) {
    const float m = 0.5f * (lo + hi);
    return m > lo ? m : hi;
}
}  // namespace

float Hierarchy::SplitValue(Worker& w, int dim, int buf, uint32_t begin, uint32_t end,
                            const Bounds6& tight) {
    const float lo = tight.lo[dim], hi = tight.hi[dim];
    if (params_.splitRule == SplitRule::kMedian) {
        const float* x = coord_[buf][dim].data();
        w.keys.assign(x + begin, x + end);
        const auto m = w.keys.begin() + w.keys.size() / 2;
        std::nth_element(w.keys.begin(), m, w.keys.end());
        return *m > lo ? *m : std::nextafter(lo, kInf);
    }
    return Midpoint(lo, hi);
}

Hierarchy::Split Hierarchy::Partition(Worker& w, int face, int dim, float value, int buf,
                                      uint32_t begin, uint32_t end, Bounds6& leftBox,
                                      Bounds6& rightBox) {
    Split split{begin, buf, true};
    uint32_t first = 0;
    bool firstLeft = true;
    if (AlreadySplit(coord_[buf][dim].data(), value, begin, end, &first, &firstLeft)) {
        // Only the children's bounds to find: the same minima and maxima a move would gather.
        split.leftFirst = firstLeft;
        split.mid = begin + first;
        (firstLeft ? leftBox : rightBox) = Bounds(face, buf, begin, split.mid);
        (firstLeft ? rightBox : leftBox) = Bounds(face, buf, split.mid, end);
        return split;
    }
    const int other = buf ^ 1;
    w.counters.rayMoves += end - begin;
    PartitionIo io = Between(coord_[buf], coord_[other], id_[buf], id_[other]);
    io.key = coord_[buf][dim].data();
    int mask = 0;
    for (int k = 0; k < kCoords; ++k) mask |= active_[face][k] ? 1 << k : 0;
    split.mid = DispatchPartition(mask, io, value, begin, end, leftBox, rightBox);
    split.buf = other;
    SetConstants(face, leftBox);
    SetConstants(face, rightBox);
    return split;
}

namespace {

// What BucketRays reads: the plan's levels, the dimension each splits and the splits' values in
// heap order (plan node h's children are 2h + 1 and 2h + 2; the cells are the last level's).
struct CellRule {
    int levels;
    const int* dim;
    const float* value;
};

#if defined(__AVX512F__)
// The cells of `rule` of the 16 rays from i on, as cell numbers.
__m512i CellsOf16(const PartitionIo& io, const CellRule& rule, __m512 split, uint32_t i,
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
__m512 SplitValues16(const CellRule& rule) {
    float values[16] = {};
    std::copy(rule.value, rule.value + (1 << rule.levels) - 1, values);
    return _mm512_loadu_ps(values);
}

// Calls f(c, lanes) for each cell c among the live lanes, with the lanes in it.
template <typename F>
void EachCell(__m512i cells, __mmask16 live, const F& f) {
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
#else
int CellOf(const PartitionIo& io, const CellRule& rule, uint32_t i) {
    int h = 0;
    for (int l = 0; l < rule.levels; ++l)
        h = 2 * h + (io.src[rule.dim[l]][i] < rule.value[h] ? 1 : 2);
    return h - ((1 << rule.levels) - 1);
}
#endif

// Adds the rays [begin, end) of `io` to the counts of their cells of `rule`.
void CountCells(const PartitionIo& io, const CellRule& rule, uint32_t begin, uint32_t end,
                uint32_t* count) {
#if defined(__AVX512F__)
    const __m512 split = SplitValues16(rule);
    for (uint32_t i = begin; i < end; i += 16) {
        const __mmask16 live = LiveLanes16(end, i);
        EachCell(CellsOf16(io, rule, split, i, live), live,
                 [&](int c, __mmask16 m) { count[c] += uint32_t(std::popcount(unsigned(m))); });
    }
#else
    for (uint32_t i = begin; i < end; ++i) ++count[CellOf(io, rule, i)];
#endif
}

// Writes the rays [begin, end) of `io` to their cells, cell c's from next[c] on in ray order, and
// gathers each cell's bounds of the active coordinates (the others are left empty).
void ScatterCells(const PartitionIo& io, const bool* active, const CellRule& rule, uint32_t begin,
                  uint32_t end, uint32_t* next, Bounds6* cell) {
    const int nCells = 1 << rule.levels;
    for (int c = 0; c < nCells; ++c) cell[c] = EmptyBounds();
#if defined(__AVX512F__)
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
        EachCell(CellsOf16(io, rule, split, i, live), live, [&](int c, __mmask16 m) {
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
#else
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
#endif
}

// Puts the rays [begin, end) of `io` into the cells of `rule`, each cell's rays in ray order,
// cells one after another from `begin` (cellBegin[c] is where cell c starts), and gathers each
// cell's bounds of the active coordinates on the way. A ray goes right at a level when its key is
// not below the split value, as Partition decides. `pieces` threads share the work, each counting
// and then moving a run of the rays; the result does not depend on their number.
void BucketRays(const PartitionIo& io, const bool* active, const CellRule& rule, uint32_t begin,
                uint32_t end, uint32_t* cellBegin, Bounds6* cell, int pieces) {
    const int nCells = 1 << rule.levels;
    // Runs of a multiple of 16 rays, so that the vector path sees the same blocks.
    const uint32_t step =
        ((end - begin + uint32_t(pieces) * 16 - 1) / (uint32_t(pieces) * 16)) * 16;
    std::vector<std::array<uint32_t, 16>> count(static_cast<size_t>(pieces));
    std::vector<std::array<Bounds6, 16>> bounds(static_cast<size_t>(pieces));
    std::barrier counted(pieces);
    OnThreads(pieces, [&](int t) {
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

// The union of bounds cell[lo, hi).
Bounds6 Union(const Bounds6* cell, int lo, int hi) {
    Bounds6 b = EmptyBounds();
    for (int c = lo; c < hi; ++c) Merge(b, cell[c]);
    return b;
}

}  // namespace

const Hierarchy::Plan& Hierarchy::MakePlan(Worker& w, int face, int dim, int buf, uint32_t begin,
                                           uint32_t end, const Bounds6& tight) {
    Plan p;
    // The dimensions: the node's own choice, then ChooseSplit's on the halved interval.
    float extent[kDims];
    for (int k = 0; k < kDims; ++k) extent[k] = tight.hi[k] - tight.lo[k];
    for (p.levels = 0; p.levels < kPlanLevels && dim >= 0; ++p.levels) {
        p.dim[p.levels] = dim;
        extent[dim] *= 0.5f;
        dim = SplitDim(face, extent);
    }
    // The values: each plan node splits its part of the interval in the middle.
    Box5 box[(1 << kPlanLevels) - 1];
    box[0] = tight.ToBox5();
    const int nInner = (1 << p.levels) - 1;
    for (int h = 0; h < nInner; ++h) {
        const int level = std::bit_width(unsigned(h + 1)) - 1;
        const int d = p.dim[level];
        p.value[h] = Midpoint(box[h].lo[d], box[h].hi[d]);
        if (2 * h + 2 < nInner) {
            box[2 * h + 1] = box[2 * h + 2] = box[h];
            box[2 * h + 1].hi[d] = box[2 * h + 2].lo[d] = p.value[h];
        }
    }
    p.buf = buf ^ 1;
    // A big node with threads waiting for work (a face's root, before its first split) shares
    // the moves with them.
    int pieces = 1;
    if (end - begin >= kParallelPlanRays) {
        std::lock_guard lock(w.schedule->mutex);
        pieces = std::max(1, w.schedule->threads - w.schedule->busy + 1);
    }
    BucketRays(Between(coord_[buf], coord_[p.buf], id_[buf], id_[p.buf]), active_[face],
               {p.levels, p.dim, p.value}, begin, end, p.cellBegin, p.cell, pieces);
    for (int c = 0; c < 1 << p.levels; ++c) SetConstants(face, p.cell[c]);
    w.counters.rayMoves += end - begin;
    ++w.counters.plans;
    w.counters.sharedPlans += pieces > 1 ? 1 : 0;
    return w.plans.emplace_back(p);
}

bool Hierarchy::PlannedSplit(const PlanAt& at, uint32_t begin, uint32_t end, uint32_t& split,
                             Bounds6 childBox[2], PlanAt childAt[2]) const {
    const Plan& p = *at.plan;
    int lo = at.cellLo, hi = at.cellHi;
    for (int level = at.level; level < p.levels; ++level) {
        const int mid = (lo + hi) / 2;
        if (p.cellBegin[mid] == begin) {
            lo = mid;
        } else if (p.cellBegin[mid] == end) {
            hi = mid;
        } else {
            split = p.cellBegin[mid];
            childBox[0] = Union(p.cell, lo, mid);
            childBox[1] = Union(p.cell, mid, hi);
            const bool last = level + 1 == p.levels;
            childAt[0] = last ? PlanAt{} : PlanAt{&p, level + 1, lo, mid};
            childAt[1] = last ? PlanAt{} : PlanAt{&p, level + 1, mid, hi};
            return true;
        }
    }
    return false;
}

void Hierarchy::EmitLeaf(Worker& w, uint32_t node, uint32_t begin, uint32_t end, int buf,
                         const ListView& list, float endHi) {
    RcLeaf leaf{};
    // Leaves fill their faces' ranges in order, and the faces follow each other in rayIndex:
    // the ids go straight to their place there, and Join sorts the leaves by it.
    leaf.rayBegin = begin + rayShift_[At(w, node).face];
    leaf.rayCount = end - begin;
    std::copy(id_[buf].begin() + begin, id_[buf].begin() + end, rayOut_ + leaf.rayBegin);
    // The current nearest-hit bound: no ray of the leaf gets past X = endHi, and the list is
    // sorted by near X, so everything after that is cut at once (Filter has already cut it when
    // the leaf filtered its own list).
    const size_t n = size_t(std::upper_bound(list.x0, list.x0 + list.n, endHi) - list.x0);
    std::vector<RcCandidate>& candidates = w.candidates;
    leaf.candBegin = uint32_t(candidates.size());
    leaf.candCount = uint32_t(n);
    candidates.resize(leaf.candBegin + n);
    RcCandidate* cand = candidates.data() + leaf.candBegin;
    for (size_t i = 0; i < n; ++i) cand[i] = {list.prim[i], list.x0[i]};
    leaf.face = At(w, node).face;
    leaf.node = node;
    w.leaves.push_back(leaf);
    w.counters.maxDepth = std::max<uint32_t>(w.counters.maxDepth, At(w, node).depth);
}

uint32_t Hierarchy::Route(const Ray5& r) const {
    uint32_t node = FaceRoot(r.face);
    while (!nodes_[node].IsLeaf()) {
        const Node& n = nodes_[node];
        if (nodes_[n.child[0]].box.Contains(r.p)) {
            node = n.child[0];
        } else if (nodes_[n.child[1]].box.Contains(r.p)) {
            node = n.child[1];
        } else if (n.remainder != kNoNode) {
            node = n.remainder;
        } else {
            return kNoNode;
        }
    }
    return node;
}

size_t Hierarchy::MemoryBytes() const {
    size_t bytes = nodes_.capacity() * sizeof(Node);
    for (const auto& l : *faceLists_) bytes += l.Bytes();
    return bytes + counters_.scratchBytes;
}

}  // namespace rayclass::classify
