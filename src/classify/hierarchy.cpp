#include "rayclass/classify/hierarchy.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "filter.h"
#include "partition.h"
#include "rayclass/core/radix_sort.h"
#include "support.h"

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

// Scenes smaller than this sort their face lists on one thread: starting threads costs more.
constexpr uint32_t kParallelSortMin = 16384;
// Generations with fewer rays are subdivided on one thread, for the same reason.
constexpr uint32_t kParallelRaysMin = 32768;
// Plans for fewer rays move them on one thread.
constexpr uint32_t kParallelPlanRays = 131072;
// Batches with fewer candidates in the workers' own arrays copy them on one thread.
constexpr size_t kParallelCopyMin = size_t(1) << 17;
// Entries of output room a worker claims at a time for its leaves' lists (a longer list claims
// its own). Claims are rare enough not to contend; a worker leaves less than a chunk unused.
constexpr size_t kOutputListChunk = size_t(1) << 16;
// Nodes with more than max(kTaskRaysMin, rays / kTasks) rays hand their later children to the
// task queue: enough tasks to balance the threads, few enough that their kept lists cost little
// (Conference with mirror rays, batches of 2^18: render 1.29 s with a minimum of 4,096 rays,
// 1.22 s with 32,768, 1.18 s on one thread without tasks).
constexpr uint32_t kTaskRaysMin = 32768;
constexpr uint32_t kTasks = 32;
// Entries per chunk of a worker's list arenas (a longer list gets a chunk of its own).
constexpr size_t kListChunk = size_t(1) << 18;

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
    const int threads = nPrims < kParallelSortMin
                            ? 1
                            : int(std::clamp(std::thread::hardware_concurrency(), 1u, 6u));
    std::vector<Bounds3f> boxes(nPrims);
    OnThreads(threads, [&](int t) {
        const uint32_t step = (nPrims + uint32_t(threads) - 1) / uint32_t(threads);
        const uint32_t end = std::min(nPrims, uint32_t(t) * step + step);
        for (uint32_t id = uint32_t(t) * step; id < end; ++id) {
            boxes[id] = scene.PrimitiveBounds(id);
            boxes[id].lo -= glm::vec3(params_.padding);
            boxes[id].hi += glm::vec3(params_.padding);
        }
    });
    // A face's frame permutes and negates the world axes, so the union of its boxes is the
    // union of the world boxes in its frame, and its sort key (the near X) is a world bound.
    Bounds3f all;
    for (const Bounds3f& b : boxes) all.Grow(b);
    auto lists = std::make_shared<std::array<FaceList, kFaceCount>>();
    for (int face = 0; face < kFaceCount; ++face) {
        const Box5 root = BoxInFace(face, sceneBox_);
        Node n;
        n.box = root;
        n.face = uint8_t(face);
        nodes_.push_back(n);
        for (int k = 0; k < kDims; ++k)
            rootExtent_[face][k] = std::max(root.hi[k] - root.lo[k], 0.0f);
    }
    // The faces' lists are independent: built on every core, each thread reusing its arrays
    // from face to face (fresh ones cost Conference's setup 25k page faults).
    struct Scratch {
        std::vector<float> key;
        std::vector<uint32_t> order;
        RadixScratch sort;
    };
    auto buildFace = [&](int face, Scratch& scratch) {
        const Box5 frameBox = BoxInFace(face, all);
        const ListFrame& frame = listFrame_[face] =
            MakeListFrame(frameBox.lo.data(), frameBox.hi.data());
        // The list in distance order: near side along the face's main axis, ties by id for
        // determinism.
        std::vector<float>& key = scratch.key;
        key.resize(nPrims);
        for (uint32_t id = 0; id < nPrims; ++id) key[id] = BoxInFace(face, boxes[id]).lo[0];
        std::vector<uint32_t>& order = scratch.order;
        SortedOrder(key, order, scratch.sort);
        // The boxes in list order, each read once: gathering six step arrays by the order cost
        // six random reads an entry.
        FaceList& l = (*lists)[face];
        l.Resize(nPrims);
        FillFaceList(face, frame, boxes.data(), order.data(), nPrims, Out(l, 0));
    };
    OnThreads(threads, [&](int t) {
        Scratch scratch;
        for (int face = t; face < kFaceCount; face += threads) buildFace(face, scratch);
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

uint32_t Hierarchy::TaskCut(uint32_t nRays) const {
    return params_.taskRays > 0 ? params_.taskRays : std::max(kTaskRaysMin, nRays / kTasks);
}

void Hierarchy::Subdivide(LeafBatch& out) {
    counters_ = {};
    // rayIndex is resized, not cleared (and candidates regrown in Join): every slot is written
    // again, and filling them with zeros first would cost a pass on one thread.
    out.leaves.clear();
    out.missed.clear();
    out.nRays = nInserted_;
    if (SubdivideFromEnds(out)) return;
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
            active_[f][k] = Varies(faceBounds[f], k);
            constant_[f][k] = faceBounds[f].lo[k];
        }
    }
    Schedule schedule;
    schedule.cut = TaskCut(n);
    nParts_ = 0;
    for (int f = 0; f < kFaceCount; ++f) {
        if (begin[f] == end[f]) continue;
        const FaceList& all = (*faceLists_)[f];
        schedule.queue.push_back({FaceRoot(f), begin[f], end[f], 0, faceBounds[f],
                                  View(all, all.Size(), &listFrame_[f]), false, PlanAt(),
                                  &NewPart(begin[f]), CellAt()});
    }
    const int threads = StartWorkers(schedule, n, out);
    OnThreads(threads, [&](int t) { Work(workers_[size_t(t)], t); });
    Join(out, schedule.listsEnd.load(), threads);
    rayOut_ = nullptr;
    // The ray buffers by the rays they hold (two ping-pong buffers and the routing
    // destinations): their face slabs reserve kFaceCount times as much address space, of which
    // only the pages rays are written to are touched.
    FinishWorkers(size_t(n) * (2 * (kCoords + 1) + 1) * 4);
}

int Hierarchy::StartWorkers(Schedule& schedule, uint32_t nRays, LeafBatch& out) {
    // The leaves' lists are written straight into out.candidates (see ListRoom), not into the
    // workers' arrays and copied there, which cost a second copy of every list and its pages
    // (sibenik_mirror, 1024 x 768: 445k page faults in all).
    Regrow(out.candidates, std::min<size_t>(listRoom_, kOwnList - 1));
    schedule.lists = out.candidates.data();
    schedule.listRoom = out.candidates.size();
    const int threads = Threads(nRays);
    schedule.threads = threads;
    if (workers_.size() < size_t(threads)) workers_.resize(size_t(threads));
    for (Worker& w : workers_) {
        w.counters = {};
        w.schedule = &schedule;
        w.leaves.clear();
        w.listAt = w.listEnd = 0;
        w.nodes.clear();
        w.kept.chunk = w.kept.used = w.stack.chunk = w.stack.used = 0;
        w.plans.clear();
    }
    return threads;
}

void Hierarchy::FinishWorkers(size_t scratch) {
    for (Worker& w : workers_) {
        counters_.boxTests += w.counters.boxTests;
        counters_.rayMoves += w.counters.rayMoves;
        counters_.plans += w.counters.plans;
        counters_.sharedPlans += w.counters.sharedPlans;
        counters_.maxDepth = std::max(counters_.maxDepth, w.counters.maxDepth);
        // (The workers' own lists are gone by now: Join frees them.)
        scratch += w.keys.capacity() * 4 + w.leaves.capacity() * sizeof(RcLeaf) +
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
        if (task.cells.root != kNoNode) {
            ProcessCells(w, task.cells, task.list, task.reuseList);
        } else {
            Process(w, task.node, task.begin, task.end, task.buf, task.tight, task.list,
                    task.reuseList, task.plan);
        }
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
        s.queue.push_back({root, begin, end, buf, tight, list, reuseList, plan, &part, CellAt()});
    }
    s.changed.notify_one();
}

void Hierarchy::Join(LeafBatch& out, size_t listsEnd, int threads) {
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
    // Leaves whose lists lie in their worker's own array keep a pointer to them.
    struct Placed {
        RcLeaf leaf;
        const RcCandidate* own;
    };
    std::vector<Placed> leaves;
    size_t nOwn = 0;
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
            const bool own = (leaf.candBegin & kOwnList) != 0;
            leaves.push_back(
                {leaf, own ? w.candidates.data() + (leaf.candBegin & ~kOwnList) : nullptr});
            if (own) nOwn += leaf.candCount;
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
    // Leaves in ray order (their ranges are disjoint and cover rayIndex).
    std::sort(leaves.begin(), leaves.end(),
              [](const Placed& a, const Placed& b) { return a.leaf.rayBegin < b.leaf.rayBegin; });
    out.leaves.resize(leaves.size());
    std::vector<uint32_t> ownLeaves;
    size_t at = listsEnd;
    for (size_t i = 0; i < leaves.size(); ++i) {
        out.leaves[i] = leaves[i].leaf;
        if (!leaves[i].own) continue;
        out.leaves[i].candBegin = uint32_t(at);
        at += leaves[i].leaf.candCount;
        ownLeaves.push_back(uint32_t(i));
    }
    // The lists the room could not take go after the claimed ones: shrinking first means growing
    // past the capacity moves only the claimed part.
    out.candidates.resize(listsEnd);
    out.candidates.resize(listsEnd + nOwn);
    listRoom_ = 2 * out.candidates.size();
    if (nOwn == 0) return;
    // Their copy, split between the threads at a leaf near the middle of the entries.
    if (nOwn < kParallelCopyMin) threads = 1;
    std::vector<size_t> from(size_t(threads) + 1, ownLeaves.size());
    from[0] = 0;
    for (int t = 1; t < threads; ++t) {
        const size_t want = listsEnd + nOwn * size_t(t) / size_t(threads);
        from[size_t(t)] = size_t(
            std::partition_point(ownLeaves.begin(), ownLeaves.end(),
                                 [&](uint32_t l) { return out.leaves[l].candBegin < want; }) -
            ownLeaves.begin());
    }
    OnThreads(threads, [&](int t) {
        for (size_t k = from[size_t(t)]; k < from[size_t(t) + 1]; ++k) {
            const uint32_t l = ownLeaves[k];
            std::copy_n(leaves[l].own, out.leaves[l].candCount,
                        out.candidates.begin() + out.leaves[l].candBegin);
        }
    });
    // Used when the room ran out, which the next generations' room avoids: not kept.
    for (Worker& w : workers_) ScratchVector<RcCandidate>().swap(w.candidates);
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
    in.n = CountUpTo(list, endHi);
    ListArena& arena = keep ? w.kept : w.stack;
    const ListOut out = Take(arena, in.n);
    // Every ray's reach is its end minus its start X, so the node's is at most endHi - lo X.
    const float reach = endHi - tight.lo[0];
    const size_t kept = FilterList(MakeBeamTest(*list.frame, tight.ToBox5(), reach), in, out);
    w.counters.boxTests += in.n;
    arena.used += kept;
    return {out.x0, out.x1, out.y0, out.y1, out.z0, out.z1, out.prim, kept, list.frame};
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
    const ArenaMark release(w.stack);
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
    split.mid = PartitionRays(mask, io, value, begin, end, leftBox, rightBox);
    split.buf = other;
    SetConstants(face, leftBox);
    SetConstants(face, rightBox);
    return split;
}

namespace {

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
    PushLeaf(w, leaf, node, list, endHi);
}

void Hierarchy::PushLeaf(Worker& w, RcLeaf leaf, uint32_t node, const ListView& list, float endHi) {
    // The current nearest-hit bound: no ray of the leaf gets past X = endHi, and the list is
    // sorted by near X, so everything after that is cut at once (Filter has already cut it when
    // the leaf filtered its own list).
    const size_t n = CountUpTo(list, endHi);
    leaf.candCount = uint32_t(n);
    RcCandidate* cand = ListRoom(w, n, leaf.candBegin);
    for (size_t i = 0; i < n; ++i) cand[i] = {list.prim[i], WorldBelow(*list.frame, 0, list.x0[i])};
    leaf.face = At(w, node).face;
    leaf.node = node;
    w.leaves.push_back(leaf);
    w.counters.maxDepth = std::max<uint32_t>(w.counters.maxDepth, At(w, node).depth);
}

RcCandidate* Hierarchy::ListRoom(Worker& w, size_t n, uint32_t& begin) {
    if (n > w.listEnd - w.listAt) {
        Schedule& s = *w.schedule;
        const size_t take = std::max(n, kOutputListChunk);
        size_t at = s.listsEnd.load(std::memory_order_relaxed);
        do {
            if (at + take > s.listRoom) {
                begin = kOwnList | uint32_t(w.candidates.size());
                w.candidates.resize(w.candidates.size() + n);
                return w.candidates.data() + (begin & ~kOwnList);
            }
        } while (!s.listsEnd.compare_exchange_weak(at, at + take, std::memory_order_relaxed));
        if (take == n) {  // a list of a chunk or more: the current chunk stays
            begin = uint32_t(at);
            return s.lists + at;
        }
        w.listAt = at;
        w.listEnd = at + take;
    }
    begin = uint32_t(w.listAt);
    w.listAt += n;
    return w.schedule->lists + begin;
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
