#include "rayclass/classify/hierarchy.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <numeric>

#include "filter.h"

#if defined(__AVX512F__)
#include "avx512.h"
#endif

namespace rayclass::classify {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

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
    const float* src[kDims];
    float* dst[kDims];
    const uint32_t* srcId;
    uint32_t* dstId;
    const float* key;
};

// Moves the rays with key < value to the front of [begin, end) of the destination (in order) and
// the others to the back (reversed), for the dimensions in kActive only, and gathers both sides'
// bounds on the way (the other dimensions' bounds are left to the caller). Returns the first
// right-side position. kActive is a template argument so that the per-dimension registers stay
// registers.
template <int kActive>
uint32_t PartitionRays(const PartitionIo& io, float value, uint32_t begin, uint32_t end,
                       Box5& leftBox, Box5& rightBox) {
    uint32_t l = begin, r = end;
#if defined(__AVX512F__)
    const __m512 m = _mm512_set1_ps(value);
    __m512 lLo[kDims], lHi[kDims], rLo[kDims], rHi[kDims];
    for (int k = 0; k < kDims; ++k) {
        lLo[k] = rLo[k] = _mm512_set1_ps(kInf);
        lHi[k] = rHi[k] = _mm512_set1_ps(-kInf);
    }
    for (uint32_t i = begin; i < end; i += 16) {
        const uint32_t rest = end - i;
        const __mmask16 live = rest >= 16 ? __mmask16(0xFFFF) : __mmask16((1u << rest) - 1u);
        const __m512 key = _mm512_maskz_loadu_ps(live, io.key + i);
        const __mmask16 left = _mm512_mask_cmp_ps_mask(live, key, m, _CMP_LT_OQ);
        const __mmask16 right = __mmask16(live & ~left);
        const uint32_t nl = uint32_t(std::popcount(unsigned(left)));
        const uint32_t nr = uint32_t(std::popcount(unsigned(right)));
        const __mmask16 ml = __mmask16((1u << nl) - 1u), mr = __mmask16((1u << nr) - 1u);
#pragma GCC unroll 5
        for (int k = 0; k < kDims; ++k) {
            if (!((kActive >> k) & 1)) continue;
            const __m512 v = _mm512_maskz_loadu_ps(live, io.src[k] + i);
            _mm512_mask_storeu_ps(io.dst[k] + l, ml, _mm512_maskz_compress_ps(left, v));
            _mm512_mask_storeu_ps(io.dst[k] + r - nr, mr, _mm512_maskz_compress_ps(right, v));
            lLo[k] = _mm512_mask_min_ps(lLo[k], left, lLo[k], v);
            lHi[k] = _mm512_mask_max_ps(lHi[k], left, lHi[k], v);
            rLo[k] = _mm512_mask_min_ps(rLo[k], right, rLo[k], v);
            rHi[k] = _mm512_mask_max_ps(rHi[k], right, rHi[k], v);
        }
        const __m512i id = _mm512_maskz_loadu_epi32(live, io.srcId + i);
        _mm512_mask_storeu_epi32(io.dstId + l, ml, _mm512_maskz_compress_epi32(left, id));
        _mm512_mask_storeu_epi32(io.dstId + r - nr, mr, _mm512_maskz_compress_epi32(right, id));
        l += nl;
        r -= nr;
    }
    for (int k = 0; k < kDims; ++k) {
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
        for (int k = 0; k < kDims; ++k) {
            if ((kActive >> k) & 1) io.dst[k][at] = io.src[k][i];
        }
        io.dstId[at] = io.srcId[i];
        l += isLeft ? 1 : 0;
        r -= isLeft ? 0 : 1;
    }
    for (int k = 0; k < kDims; ++k) {
        if (!((kActive >> k) & 1)) continue;
        MinMax(io.dst[k] + begin, l - begin, leftBox.lo[k], leftBox.hi[k]);
        MinMax(io.dst[k] + l, end - l, rightBox.lo[k], rightBox.hi[k]);
    }
#endif
    return l;
}

template <int kActive = 0>
uint32_t DispatchPartition(int active, const PartitionIo& io, float value, uint32_t begin,
                           uint32_t end, Box5& leftBox, Box5& rightBox) {
    if constexpr (kActive == 1 << kDims) {
        return begin;
    } else {
        if (active == kActive) return PartitionRays<kActive>(io, value, begin, end, leftBox, rightBox);
        return DispatchPartition<kActive + 1>(active, io, value, begin, end, leftBox, rightBox);
    }
}

}  // namespace

void Hierarchy::FaceList::Resize(size_t n) {
    for (auto* a : {&x0, &x1, &y0, &y1, &z0, &z1}) a->resize(n);
    prim.resize(n);
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
    std::vector<uint32_t> order(nPrims);
    std::vector<Box5> inFace(nPrims);
    for (int face = 0; face < kFaceCount; ++face) {
        const Box5 root = BoxInFace(face, sceneBox_);
        NewNode(root, face, 0, false);
        for (int k = 0; k < kDims; ++k) rootExtent_[face][k] = std::max(root.hi[k] - root.lo[k], 0.0f);
        for (uint32_t id = 0; id < nPrims; ++id) inFace[id] = BoxInFace(face, boxes[id]);
        // The distance order: near side along the face's main axis, ties by id for determinism.
        std::iota(order.begin(), order.end(), 0u);
        std::sort(order.begin(), order.end(), [&](uint32_t a, uint32_t b) {
            return inFace[a].lo[0] < inFace[b].lo[0] || (inFace[a].lo[0] == inFace[b].lo[0] && a < b);
        });
        FaceList& l = faceLists_[face];
        l.Resize(nPrims);
        for (uint32_t i = 0; i < nPrims; ++i) {
            const Box5& b = inFace[order[i]];
            l.x0[i] = b.lo[0];
            l.x1[i] = b.hi[0];
            l.y0[i] = b.lo[1];
            l.y1[i] = b.hi[1];
            l.z0[i] = b.lo[2];
            l.z1[i] = b.hi[2];
            l.prim[i] = order[i];
        }
    }
    levelLists_.resize(size_t(params_.maxDepth) + 2);
}

void Hierarchy::Reset() {
    nodes_.resize(kFaceCount);
    for (Node& n : nodes_) {
        n.child[0] = n.child[1] = n.remainder = kNoNode;
    }
}

uint32_t Hierarchy::NewNode(const Box5& box, int face, int depth, bool isRemainder) {
    Node n;
    n.box = box;
    n.face = uint8_t(face);
    n.depth = uint8_t(depth);
    n.isRemainder = isRemainder ? 1 : 0;
    nodes_.push_back(n);
    return uint32_t(nodes_.size() - 1);
}

void Hierarchy::Insert(std::span<const Ray> rays) {
    inserted_.push_back(rays);
    nInserted_ += uint32_t(rays.size());
}

void Hierarchy::Subdivide(LeafBatch& out) {
    counters_ = {};
    out.leaves.clear();
    out.rayIndex.clear();
    out.candidates.clear();
    out.missed.clear();
    out.nRays = nInserted_;
    ray5_.resize(nInserted_);
    uint32_t count[kFaceCount + 1] = {};
    float reach[kFaceCount] = {};
    const bool empty = sceneBox_.Empty();
    uint32_t id = 0;
    for (const auto& rays : inserted_) {
        for (const Ray& ray : rays) {
            Ray5& r = ray5_[id++];
            if (empty || !ToRay5(ray, sceneBox_, r)) r.face = kFaceCount;
            ++count[r.face];
        }
    }
    const uint32_t n = nInserted_ - count[kFaceCount];
    for (int b = 0; b < 2; ++b) {
        for (auto& c : coord_[b]) c.resize(n);
        id_[b].resize(n);
    }
    dest_.resize(n);
    uint32_t begin[kFaceCount + 1] = {};
    for (int f = 0; f < kFaceCount; ++f) begin[f + 1] = begin[f] + count[f];
    uint32_t next[kFaceCount];
    std::copy(begin, begin + kFaceCount, next);
    out.missed.reserve(count[kFaceCount]);
    for (uint32_t i = 0; i < nInserted_; ++i) {
        const Ray5& r = ray5_[i];
        if (r.face == kFaceCount) {
            out.missed.push_back(i);
            continue;
        }
        const uint32_t at = next[r.face]++;
        for (int k = 0; k < kDims; ++k) coord_[0][k][at] = r.p[k];
        id_[0][at] = i;
        reach[r.face] = std::max(reach[r.face], r.reach);
    }
    out.rayIndex.resize(n);
    for (int f = 0; f < kFaceCount; ++f) {
        if (count[f] == 0) continue;
        faceReach_ = reach[f];
        BuildFace(f, begin[f], begin[f + 1], out);
    }
    size_t scratch = (dest_.capacity() + keys_.capacity()) * 4 + ray5_.capacity() * sizeof(Ray5);
    for (int b = 0; b < 2; ++b) scratch += (id_[b].capacity() + coord_[b][0].capacity() * kDims) * 4;
    for (const auto& l : levelLists_) scratch += l.Bytes();
    counters_.scratchBytes = std::max(counters_.scratchBytes, scratch);
    inserted_.clear();
    nInserted_ = 0;
}

void Hierarchy::BuildFace(int face, uint32_t begin, uint32_t end, LeafBatch& out) {
    std::fill(std::begin(active_), std::end(active_), true);
    const Box5 tight = Bounds(0, begin, end);
    // Dimensions that do not vary among the face's rays (the origin of eye rays) are never moved.
    for (int k = 0; k < kDims; ++k) {
        active_[k] = tight.lo[k] < tight.hi[k];
        constant_[k] = tight.lo[k];
    }
    const FaceList& all = faceLists_[face];
    Process(FaceRoot(face), begin, end, 0, tight, View(all, all.Size()), false, out);
}

Box5 Hierarchy::Bounds(int buf, uint32_t begin, uint32_t end) const {
    Box5 b;
    for (int k = 0; k < kDims; ++k) {
        if (active_[k]) {
            MinMax(coord_[buf][k].data() + begin, end - begin, b.lo[k], b.hi[k]);
        } else {
            b.lo[k] = b.hi[k] = constant_[k];
        }
    }
    return b;
}

ListView Hierarchy::Filter(const Box5& tight, const ListView& list, int level) {
    FaceList& dst = levelLists_[size_t(level)];
    if (dst.Size() < list.n) dst.Resize(list.n);
    const size_t kept = FilterList(MakeBeamTest(tight, faceReach_), list, dst);
    counters_.boxTests += list.n;
    return View(dst, kept);
}

void Hierarchy::Process(uint32_t node, uint32_t begin, uint32_t end, int buf, const Box5& tight,
                        const ListView& list, bool reuseList, LeafBatch& out) {
    const int depth = nodes_[node].depth;
    const int face = nodes_[node].face;
    const int other = buf ^ 1;
    if (!nodes_[node].IsLeaf()) {
        // A node split by an earlier generation: route by containment, the rest to the remainder.
        const ListView own = Filter(tight, list, depth);
        const Box5 box0 = nodes_[nodes_[node].child[0]].box;
        const Box5 box1 = nodes_[nodes_[node].child[1]].box;
        uint32_t count[3] = {};
        for (uint32_t i = begin; i < end; ++i) {
            std::array<float, kDims> p;
            for (int k = 0; k < kDims; ++k) p[k] = active_[k] ? coord_[buf][k][i] : constant_[k];
            const uint32_t g = box0.Contains(p) ? 0 : (box1.Contains(p) ? 1 : 2);
            dest_[i] = g;
            ++count[g];
        }
        const uint32_t start[3] = {begin, begin + count[0], begin + count[0] + count[1]};
        uint32_t next[3] = {start[0], start[1], start[2]};
        for (uint32_t i = begin; i < end; ++i) dest_[i] = next[dest_[i]]++;
        for (int k = 0; k < kDims; ++k) {
            if (!active_[k]) continue;
            for (uint32_t i = begin; i < end; ++i) coord_[other][k][dest_[i]] = coord_[buf][k][i];
        }
        for (uint32_t i = begin; i < end; ++i) id_[other][dest_[i]] = id_[buf][i];
        counters_.rayMoves += end - begin;
        for (int g = 0; g < 3; ++g) {
            if (count[g] == 0) continue;
            uint32_t target;
            if (g < 2) {
                target = nodes_[node].child[g];
            } else {
                target = nodes_[node].remainder;
                if (target == kNoNode) {
                    target = NewNode(nodes_[node].box, face, depth + 1, true);
                    nodes_[node].remainder = target;
                }
            }
            const uint32_t b = start[g], e = start[g] + count[g];
            Process(target, b, e, other, Bounds(other, b, e), own, false, out);
        }
        return;
    }

    ListView own = reuseList ? list : Filter(tight, list, depth);
    int dim = 0;
    uint32_t mid = begin;
    Box5 leftBox, rightBox;
    if (ChooseSplit(nodes_[node], tight, end - begin, own, dim)) {
        const float value = SplitValue(dim, buf, begin, end, tight);
        mid = Partition(dim, value, buf, begin, end, leftBox, rightBox);
    }
    if (mid == begin || mid == end) {
        if (reuseList) own = Filter(tight, list, depth);
        EmitLeaf(node, begin, end, buf, tight, own, out);
        return;
    }
    const uint32_t left = NewNode(leftBox, face, depth + 1, false);
    const uint32_t right = NewNode(rightBox, face, depth + 1, false);
    nodes_[node].child[0] = left;
    nodes_[node].child[1] = right;
    const bool reuse = (depth + 1) % std::max(params_.splitsPerList, 1) != 0;
    Process(left, begin, mid, other, leftBox, own, reuse, out);
    Process(right, mid, end, other, rightBox, own, reuse, out);
}

bool Hierarchy::ChooseSplit(const Node& node, const Box5& tight, uint32_t nRays,
                            const ListView& list, int& dim) const {
    const Params& p = params_;
    if (nRays <= p.minRays || list.n <= p.minCandidates || node.depth >= p.maxDepth) return false;
    float best = 0.0f;
    dim = -1;
    for (int k = 0; k < kDims; ++k) {
        const float root = rootExtent_[node.face][k];
        const float extent = tight.hi[k] - tight.lo[k];
        const bool isDir = k >= 3;
        const float minExtent = root * (isDir ? p.minDirFraction : p.minOriginFraction);
        if (!(extent > minExtent)) continue;
        const float rel = extent / root * (isDir ? p.dirWeight : 1.0f);
        if (rel > best) {
            best = rel;
            dim = k;
        }
    }
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
    const double cost = 2.0 * double(list.n) * p.boxTestCost + double(nRays) * p.rayMoveCost;
    return saved > cost;
}

float Hierarchy::SplitValue(int dim, int buf, uint32_t begin, uint32_t end, const Box5& tight) {
    const float lo = tight.lo[dim], hi = tight.hi[dim];
    if (params_.splitRule == SplitRule::kMedian) {
        const float* x = coord_[buf][dim].data();
        keys_.assign(x + begin, x + end);
        const auto m = keys_.begin() + keys_.size() / 2;
        std::nth_element(keys_.begin(), m, keys_.end());
        return *m > lo ? *m : std::nextafter(lo, kInf);
    }
    const float m = 0.5f * (lo + hi);
    // When lo and hi are adjacent floats the middle rounds onto lo; hi still splits them.
    return m > lo ? m : hi;
}

uint32_t Hierarchy::Partition(int dim, float value, int buf, uint32_t begin, uint32_t end,
                              Box5& leftBox, Box5& rightBox) {
    const int other = buf ^ 1;
    counters_.rayMoves += end - begin;
    PartitionIo io;
    int mask = 0;
    for (int k = 0; k < kDims; ++k) {
        io.src[k] = coord_[buf][k].data();
        io.dst[k] = coord_[other][k].data();
        mask |= active_[k] ? 1 << k : 0;
    }
    io.srcId = id_[buf].data();
    io.dstId = id_[other].data();
    io.key = coord_[buf][dim].data();
    const uint32_t mid = DispatchPartition(mask, io, value, begin, end, leftBox, rightBox);
    for (int k = 0; k < kDims; ++k) {
        if (!active_[k]) leftBox.lo[k] = leftBox.hi[k] = rightBox.lo[k] = rightBox.hi[k] = constant_[k];
    }
    return mid;
}

void Hierarchy::EmitLeaf(uint32_t node, uint32_t begin, uint32_t end, int buf, const Box5& tight,
                         const ListView& list, LeafBatch& out) {
    RcLeaf leaf{};
    // Faces and leaves fill the range in order, so a leaf's rays keep their buffer positions.
    leaf.rayBegin = begin;
    leaf.rayCount = end - begin;
    float reach = 0.0f;
    for (uint32_t i = begin; i < end; ++i) {
        const uint32_t id = id_[buf][i];
        out.rayIndex[i] = id;
        reach = std::max(reach, ray5_[id].reach);
    }
    // The current nearest-hit bound: no ray of the leaf gets farther along X than tight.hi[0] +
    // reach, and the list is sorted by near X, so everything after that is cut at once.
    const float farthest = tight.hi[0] + reach;
    const size_t n = size_t(std::upper_bound(list.x0, list.x0 + list.n, farthest) - list.x0);
    leaf.candBegin = uint32_t(out.candidates.size());
    leaf.candCount = uint32_t(n);
    out.candidates.resize(leaf.candBegin + n);
    RcCandidate* cand = out.candidates.data() + leaf.candBegin;
    for (size_t i = 0; i < n; ++i) cand[i] = {list.prim[i], list.x0[i]};
    leaf.face = nodes_[node].face;
    leaf.node = node;
    out.leaves.push_back(leaf);
    counters_.maxDepth = std::max<uint32_t>(counters_.maxDepth, nodes_[node].depth);
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
    for (const auto& l : faceLists_) bytes += l.Bytes();
    return bytes + counters_.scratchBytes;
}

}  // namespace rayclass::classify
