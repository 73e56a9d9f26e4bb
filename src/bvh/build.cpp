// The binary tree of bvh.h: binned SAH (Wald 2007) over primitive references that the build
// partitions in place, so that every pass reads them in order, a box's three axes at once (GCC's
// vector extensions, SSE2). The binning grows a bin's box with one AVX instruction where the CPU
// has AVX, chosen at run time, so that the build runs on any x86-64. A node takes two passes over
// its primitives: one bins them on all three axes, one partitions them and bounds both children
// on the way. Every float is computed as the scalar formulas of BinOf and HalfArea compute it, and
// the halves of a large node are binned apart whatever the threads, so the tree does not depend
// on the instruction set or the number of threads.
#include <algorithm>
#include <bit>
#include <cmath>
#include <future>
#include <limits>
#include <stdexcept>
#include <thread>
#include <vector>

#if defined(__x86_64__)
#include <immintrin.h>
#endif

#include "rayclass/bvh/bvh.h"
#include "rayclass/core/simd.h"

namespace rayclass::bvh {

namespace {

using Vec4 = float __attribute__((vector_size(16)));
using Int4 = int32_t __attribute__((vector_size(16)));

constexpr float kInf = std::numeric_limits<float>::infinity();
// Lanes x, y and z of a reference's hi (the fourth holds the primitive's id).
constexpr Int4 kXyz = {-1, -1, -1, 0};

// glm::min's and glm::max's operand order (Bounds3f::Grow), down to which of +0 and -0 is kept.
Vec4 Min4(Vec4 a, Vec4 b) { return b < a ? b : a; }
Vec4 Max4(Vec4 a, Vec4 b) { return a < b ? b : a; }

// A primitive's box in the build's working order: hi's fourth lane holds its id's bits, lo's is 0.
struct alignas(32) PrimRef {
    Vec4 lo, hi;
    uint32_t Id() const { return std::bit_cast<uint32_t>(hi[3]); }
    Vec4 Centroid() const { return (lo + Vec4(Int4(hi) & kXyz)) * 0.5f; }
};

struct Box4 {
    Vec4 lo = {kInf, kInf, kInf, kInf};
    Vec4 hi = {-kInf, -kInf, -kInf, -kInf};
    void Grow(Vec4 l, Vec4 h) {
        lo = Min4(lo, l);
        hi = Max4(hi, h);
    }
    void Grow(const Box4& b) { Grow(b.lo, b.hi); }
    bool Empty() const { return lo[0] > hi[0] || lo[1] > hi[1] || lo[2] > hi[2]; }
};

// A primitive's box and its centroid's.
struct Bounds2 {
    Box4 box, centroids;
    void Grow(const PrimRef& r) {
        box.Grow(r.lo, r.hi);
        const Vec4 c = r.Centroid();
        centroids.Grow(c, c);
    }
    void Grow(const Bounds2& b) {
        box.Grow(b.box);
        centroids.Grow(b.centroids);
    }
};

float HalfArea(const Box4& b) {
    if (b.Empty()) return 0.0f;
    const Vec4 s = b.hi - b.lo;
    return s[0] * s[1] + s[1] * s[2] + s[2] * s[0];
}

// Nodes of at least this many primitives bin their halves apart, and subtrees of at least this
// many may be built on another thread.
constexpr uint32_t kParallelPrims = 32768;

// Bin coordinates over a centroid box: the bin of a centroid along each axis, as
// int32(bins * ((c - lo) / extent)) clamped to the bins.
struct Binner {
    Binner(const Box4& centroids, uint32_t bins) : lo(centroids.lo), n(float(bins)) {
        const Vec4 extent = centroids.hi - centroids.lo;
        for (int a = 0; a < 3; ++a) split[a] = centroids.hi[a] > centroids.lo[a];
        // An axis without extent bins everything into bin 0 (and is not split along).
        ext = extent > 0.0f ? extent : Vec4{1, 1, 1, 1};
        ext[3] = 1.0f;  // the centroid's fourth lane is 0: bin 0 there too
        last = Int4{} + int32_t(bins - 1);
    }
    Vec4 lo, ext;
    float n;
    Int4 last;
    bool split[3];

    Int4 Bin(const PrimRef& r) const {
        const Int4 b = __builtin_convertvector(n * ((r.Centroid() - lo) / ext), Int4);
        const Int4 lower = b < 0 ? Int4{} : b;
        return lower > last ? last : lower;
    }
    // Bin(r)[axis], scalar.
    int32_t BinOf(const PrimRef& r, int axis) const {
        const float c = (r.lo[axis] + r.hi[axis]) * 0.5f;
        const auto b = int32_t(n * ((c - lo[axis]) / ext[axis]));
        return std::clamp<int32_t>(b, 0, last[0]);
    }
};

struct Split {
    float cost = kInf;
    int axis = -1;
    int32_t bin = 0;  // the lower child takes the bins below this one
};

// A bin's box with its upper corner negated, so that one minimum grows both corners: eight lanes
// at a time where the CPU has AVX. Min4(-a, -b) is -Max4(a, b), zeros included.
struct alignas(32) BinBox {
    Vec4 lo = {kInf, kInf, kInf, kInf};
    Vec4 negHi = {kInf, kInf, kInf, kInf};
    void Grow(const PrimRef& r) {
        lo = Min4(lo, r.lo);
        negHi = Min4(negHi, -r.hi);
    }
    void Grow(const BinBox& b) {
        lo = Min4(lo, b.lo);
        negHi = Min4(negHi, b.negHi);
    }
};

#if defined(__x86_64__)
#define RC_BVH_AVX __attribute__((target("avx")))
// RAYCLASS_SIMD=generic keeps the SSE2 twin, so that tests cover it on a CPU with AVX.
bool UseAvx() {
    static const bool avx =
        RequestedSimd() != SimdRequest::kGeneric && __builtin_cpu_supports("avx");
    return avx;
}
#endif

// A node's SAH bins on all three axes: axis a's bin b at [a * count + b].
class Bins {
  public:
    // Sets `count` bins per axis, all empty.
    void Reset(uint32_t count) {
        count_ = count;
        box_.assign(3 * count, BinBox{});
        prims_.assign(3 * count, 0u);
        used_.resize(count);
        rightArea_.resize(count);
        rightCount_.resize(count);
    }
    uint32_t Count() const { return count_; }

    void Add(const PrimRef* refs, uint32_t n, const Binner& binner) {
#if defined(__x86_64__)
        if (UseAvx()) return AddAvx(refs, n, binner);
#endif
        BinBox* box = box_.data();
        uint32_t* prims = prims_.data();
        for (uint32_t i = 0; i < n; ++i) {
            const Int4 bin = binner.Bin(refs[i]);
            for (uint32_t a = 0; a < 3; ++a) {
                const uint32_t k = a * count_ + uint32_t(bin[a]);
                box[k].Grow(refs[i]);
                ++prims[k];
            }
        }
    }
#if defined(__x86_64__)
    // Add with a bin's box grown by one 8-lane minimum (BinBox: the same floats).
    RC_BVH_AVX void AddAvx(const PrimRef* refs, uint32_t n, const Binner& binner) {
        const __m256 negateHi = _mm256_setr_ps(0, 0, 0, 0, -0.0f, -0.0f, -0.0f, -0.0f);
        float* box = reinterpret_cast<float*>(box_.data());
        uint32_t* prims = prims_.data();
        for (uint32_t i = 0; i < n; ++i) {
            const Int4 bin = binner.Bin(refs[i]);
            const __m256 r =
                _mm256_xor_ps(_mm256_load_ps(reinterpret_cast<const float*>(&refs[i])), negateHi);
            for (uint32_t a = 0; a < 3; ++a) {
                const uint32_t k = a * count_ + uint32_t(bin[a]);
                float* b = box + 8 * size_t(k);
                _mm256_store_ps(b, _mm256_min_ps(r, _mm256_load_ps(b)));  // Min4's operand order
                ++prims[k];
            }
        }
    }
#endif
    void Merge(const Bins& o) {
        for (size_t b = 0; b < box_.size(); ++b) {
            box_[b].Grow(o.box_[b]);
            prims_[b] += o.prims_[b];
        }
    }

    // The cheapest split plane along the axes the binner splits (axis < 0: none); leaves every bin
    // empty for the next node. Only the bins that hold primitives are visited: a plane between
    // two of them costs what the first plane above the lower one costs, which wins the tie.
    Split TakeBest(const Binner& binner);

  private:
    uint32_t count_ = 0;
    std::vector<BinBox> box_;
    std::vector<uint32_t> prims_;
    // TakeBest's scratch, per bin of an axis.
    std::vector<uint32_t> used_;
    std::vector<float> rightArea_;
    std::vector<uint32_t> rightCount_;
};

Split Bins::TakeBest(const Binner& binner) {
    Split best;
    for (int axis = 0; axis < 3; ++axis) {
        BinBox* box = box_.data() + uint32_t(axis) * count_;
        uint32_t* prims = prims_.data() + uint32_t(axis) * count_;
        uint32_t m = 0;
        for (uint32_t b = 0; b < count_; ++b) {
            used_[m] = b;
            m += prims[b] > 0 ? 1 : 0;
        }
        if (binner.split[axis]) {
            // Bin used_[j - 1] is the highest below the plane of candidate j, used_[j] the lowest
            // above it.
            Box4 acc;
            uint32_t cnt = 0;
            for (uint32_t j = m; j-- > 1;) {
                acc.Grow(box[used_[j]].lo, -box[used_[j]].negHi);
                cnt += prims[used_[j]];
                rightArea_[j] = HalfArea(acc);
                rightCount_[j] = cnt;
            }
            acc = Box4{};
            cnt = 0;
            for (uint32_t j = 1; j < m; ++j) {
                acc.Grow(box[used_[j - 1]].lo, -box[used_[j - 1]].negHi);
                cnt += prims[used_[j - 1]];
                const float cost =
                    HalfArea(acc) * float(cnt) + rightArea_[j] * float(rightCount_[j]);
                if (cost < best.cost) best = {cost, axis, int32_t(used_[j - 1] + 1)};
            }
        }
        for (uint32_t j = 0; j < m; ++j) {
            box[used_[j]] = BinBox{};
            prims[used_[j]] = 0;
        }
    }
    return best;
}

Bounds2 RangeBounds(const PrimRef* refs, uint32_t count) {
    Bounds2 b;
    for (uint32_t i = 0; i < count; ++i) b.Grow(refs[i]);
    return b;
}

struct Builder {
    Builder(std::span<PrimRef> refs_, float pad_, const BuildParams& params_,
            uint32_t parallelDepth_)
        : refs(refs_), pad(pad_), params(params_), parallelDepth(parallelDepth_) {}

    std::span<PrimRef> refs;  // shared: each builder partitions its own ranges of it
    float pad;
    BuildParams params;
    uint32_t parallelDepth;         // nodes above this depth build their right child apart
    std::vector<BinaryNode> nodes;  // this builder's subtree, depth first, its root at 0
    uint32_t maxDepth = 0;

    float Outward(float x, float dir) const {
        return x + dir * (pad + std::abs(x) * (1.0f / 1048576.0f));
    }

    // A node's bins, reused by every node (a node is done with them before it recurses).
    Bins bins, upperBins;

    // Bins [begin, end) into `bins`. A large node bins its two halves apart and merges them
    // (whatever the threads, so that the tree does not depend on them), on two threads while
    // fewer subtrees than threads are being built.
    void BinNode(uint32_t begin, uint32_t end, uint32_t depth, const Binner& binner, uint32_t nb) {
        if (bins.Count() != nb) bins.Reset(nb);
        const uint32_t n = end - begin;
        if (n < kParallelPrims) return bins.Add(refs.data() + begin, n, binner);
        const uint32_t half = n / 2;
        upperBins.Reset(nb);
        auto upper = [&] { upperBins.Add(refs.data() + begin + half, n - half, binner); };
        std::future<void> done;
        if (depth < parallelDepth) done = std::async(std::launch::async, upper);
        bins.Add(refs.data() + begin, half, binner);
        if (done.valid()) {
            done.get();
        } else {
            upper();
        }
        bins.Merge(upperBins);
    }

    // Hoare partition of [begin, end) by the split's side, bounding both sides as it goes
    // (each reference is tested once). Returns where the upper side starts.
    uint32_t Partition(uint32_t begin, uint32_t end, const Binner& binner, const Split& split,
                       Bounds2& lower, Bounds2& upper) {
        PrimRef* first = refs.data() + begin;
        PrimRef* last = refs.data() + end;
        auto below = [&](const PrimRef& r) { return binner.BinOf(r, split.axis) < split.bin; };
        while (true) {
            while (true) {
                if (first == last) return uint32_t(first - refs.data());
                if (!below(*first)) break;
                lower.Grow(*first++);
            }
            --last;
            while (true) {
                if (first == last) {
                    upper.Grow(*first);  // the one the lower scan stopped at
                    return uint32_t(first - refs.data());
                }
                if (below(*last)) break;
                upper.Grow(*last--);
            }
            upper.Grow(*first);
            lower.Grow(*last);
            std::swap(*first, *last);
            ++first;
        }
    }

    // Builds refs[begin, end), whose bounds are `bounds`, into node `self` (already allocated).
    void Node(uint32_t self, uint32_t begin, uint32_t end, uint32_t depth, const Bounds2& bounds) {
        if (depth > kMaxDepth) throw std::runtime_error("bvh: tree deeper than the kernels' stack");
        maxDepth = std::max(maxDepth, depth);
        const Box4& box = bounds.box;
        BinaryNode& node = nodes[self];
        node.box.lo = {Outward(box.lo[0], -1), Outward(box.lo[1], -1), Outward(box.lo[2], -1)};
        node.box.hi = {Outward(box.hi[0], 1), Outward(box.hi[1], 1), Outward(box.hi[2], 1)};
        const uint32_t n = end - begin;
        auto makeLeaf = [&] {
            BinaryNode& leaf = nodes[self];
            leaf.first = begin;
            leaf.count = n;
            leaf.axis = 0;
        };
        if (n <= 1) return makeLeaf();

        const uint32_t nb = std::max(2u, params.bins);
        const Binner binner(bounds.centroids, nb);
        BinNode(begin, end, depth, binner, nb);
        Split best = bins.TakeBest(binner);
        const float leafCost = HalfArea(box) * float(n);
        const float splitCost = params.traversalCost * HalfArea(box) + best.cost;
        if (best.axis < 0) {
            // Every centroid in one point: split in the middle of the list if it is too long.
            if (n <= params.maxLeafSize) return makeLeaf();
            best.axis = 0;
        } else if (n <= params.maxLeafSize && leafCost <= splitCost) {
            return makeLeaf();
        }
        Bounds2 lower, upper;
        uint32_t mid = best.cost < kInf ? Partition(begin, end, binner, best, lower, upper) : begin;
        if (mid == begin || mid == end) {
            // No plane or all on one side (then the partition moved nothing): halve the list.
            mid = begin + n / 2;
            lower = RangeBounds(refs.data() + begin, mid - begin);
            upper = RangeBounds(refs.data() + mid, end - mid);
        }
        Children(self, begin, mid, end, depth, lower, upper, best.axis);
    }

    void Children(uint32_t self, uint32_t begin, uint32_t mid, uint32_t end, uint32_t depth,
                  const Bounds2& lower, const Bounds2& upper, int axis) {
        const uint32_t left = uint32_t(nodes.size());
        nodes.emplace_back();
        uint32_t right;
        if (depth < parallelDepth && end - mid >= kParallelPrims) {
            // The right subtree on another thread, into its own nodes, appended after the left
            // one: the same tree, node for node, as built on one thread.
            Builder other(refs, pad, params, parallelDepth);
            other.nodes.reserve(2 * size_t(end - mid));
            other.nodes.emplace_back();
            auto done =
                std::async(std::launch::async, [&] { other.Node(0, mid, end, depth + 1, upper); });
            Node(left, begin, mid, depth + 1, lower);
            done.get();
            right = uint32_t(nodes.size());
            for (BinaryNode nd : other.nodes) {
                if (nd.count == 0) nd.first += right;  // an inner node's right child
                nodes.push_back(nd);
            }
            maxDepth = std::max(maxDepth, other.maxDepth);
        } else {
            Node(left, begin, mid, depth + 1, lower);
            right = uint32_t(nodes.size());
            nodes.emplace_back();
            Node(right, mid, end, depth + 1, upper);
        }
        BinaryNode& node = nodes[self];
        node.first = right;
        node.count = 0;
        node.axis = uint32_t(axis);
    }
};

}  // namespace

Bvh Build(std::span<const Bounds3f> boxes, float pad, const BuildParams& params) {
    Bvh out;
    if (boxes.empty()) {
        // No primitives: one node the kernels never look at (they skip traversal when the scene
        // has no primitive).
        out.nodes.emplace_back();
        out.nodes[0].first = 0;
        out.nodes[0].count = 0;
        return out;
    }
    std::vector<PrimRef> refs(boxes.size());
    Bounds2 bounds;
    for (uint32_t i = 0; i < boxes.size(); ++i) {
        const Bounds3f& b = boxes[i];
        refs[i].lo = Vec4{b.lo.x, b.lo.y, b.lo.z, 0.0f};
        refs[i].hi = Vec4{b.hi.x, b.hi.y, b.hi.z, std::bit_cast<float>(i)};
        bounds.Grow(refs[i]);
    }
    const uint32_t threads =
        params.threads > 0 ? params.threads : std::max(1u, std::thread::hardware_concurrency());
    uint32_t parallelDepth = 0;  // 2^parallelDepth subtrees at most build at once
    while ((1u << parallelDepth) < threads) ++parallelDepth;
    Builder b(refs, pad, params, parallelDepth);
    b.nodes.reserve(2 * boxes.size());
    b.nodes.emplace_back();
    b.Node(0, 0, uint32_t(boxes.size()), 0, bounds);
    out.nodes = std::move(b.nodes);
    out.maxDepth = b.maxDepth;
    out.primIndex.resize(refs.size());
    for (size_t i = 0; i < refs.size(); ++i) out.primIndex[i] = refs[i].Id();
    return out;
}

Bvh Build(const scene::Scene& scene, const BuildParams& params) {
    std::vector<Bounds3f> boxes(scene.PrimitiveCount());
    Bounds3f sceneBox;
    for (uint32_t id = 0; id < boxes.size(); ++id) {
        boxes[id] = scene.PrimitiveBounds(id);
        sceneBox.Grow(boxes[id]);
    }
    const float pad = sceneBox.Empty() ? 0.0f : 1e-6f * sceneBox.Diagonal();
    return Build(boxes, pad, params);
}

}  // namespace rayclass::bvh
