#include "workers.h"

#include <algorithm>
#include <thread>

#include "filter.h"

namespace rayclass::classify {

namespace {

// Generations with fewer rays are classified on one thread: starting threads costs more.
constexpr uint32_t kParallelRaysMin = 32768;
// Batches with fewer candidates in the workers' own arrays copy them on one thread.
constexpr size_t kParallelCopyMin = size_t(1) << 17;
// Entries of output room a worker claims at a time for its leaves' lists (a longer list claims
// its own). Claims are rare enough not to contend; a worker leaves less than a chunk unused.
constexpr size_t kOutputListChunk = size_t(1) << 16;
// Nodes with more than max(kTaskRaysMin, rays / kTasks) rays hand their later children to the
// task queue: enough tasks to balance the threads, few enough that their kept lists cost little.
constexpr uint32_t kTaskRaysMin = 32768;
constexpr uint32_t kTasks = 32;
// A worker's leaf whose list lies in the worker's own array (candBegin's top bit): the output's
// room was used up. The output's lists stay below 2^31 entries (16 GiB).
constexpr uint32_t kOwnList = 0x80000000u;

// A node id of `part` once the parts are joined: local ids become their place in the store.
uint32_t Joined(const Part& part, uint32_t id) {
    return (id & kLocal) && id < kPending ? part.base + (id & ~kLocal) : id;
}

void FixLinks(const Part& part, Node& node) {
    node.child[0] = Joined(part, node.child[0]);
    node.child[1] = Joined(part, node.child[1]);
    node.remainder = Joined(part, node.remainder);
}

}  // namespace

uint32_t Worker::NewNode(const Box5& box, int face, int depth, bool isRemainder) {
    Node n;
    n.box = box;
    n.face = uint8_t(face);
    n.depth = uint8_t(depth);
    n.isRemainder = isRemainder ? 1 : 0;
    nodes.push_back(n);
    return kLocal | uint32_t(nodes.size() - 1 - part->nodeBegin);
}

void Worker::PushLeaf(RcLeaf leaf, uint32_t node, const ListView& list, float endHi) {
    // The current nearest-hit bound: no ray of the leaf gets past X = endHi, and the list is
    // sorted by near X, so everything after that is cut at once (Filter has already cut it when
    // the leaf filtered its own list).
    const size_t n = CountUpTo(list, endHi);
    leaf.candCount = uint32_t(n);
    RcCandidate* cand = pool->ListRoom(*this, n, leaf.candBegin);
    WriteCandidates(list, n, cand);
    leaf.face = At(node).face;
    leaf.node = node;
    leaves.push_back(leaf);
    counters.maxDepth = std::max<uint32_t>(counters.maxDepth, At(node).depth);
}

WorkerPool::WorkerPool(std::vector<Node>& store, const Params& params)
    : store_(store), params_(params) {}

int WorkerPool::Threads(uint32_t nRays) const {
    if (params_.threads > 0) return int(params_.threads);
    if (nRays < kParallelRaysMin) return 1;
    return int(std::clamp(std::thread::hardware_concurrency(), 1u, 64u));
}

uint32_t WorkerPool::TaskCut(uint32_t nRays) const {
    return params_.taskRays > 0 ? params_.taskRays : std::max(kTaskRaysMin, nRays / kTasks);
}

int WorkerPool::Start(uint32_t nRays, uint32_t cut, LeafBatch& out) {
    // The leaves' lists are written straight into out.candidates (see ListRoom), not into the
    // workers' arrays and copied there, which cost a second copy of every list and its pages.
    Regrow(out.candidates, std::min<size_t>(listRoom_, kOwnList - 1));
    lists_ = out.candidates.data();
    roomNow_ = out.candidates.size();
    listsEnd_ = 0;
    cut_ = cut;
    busy_ = 0;
    nParts_ = 0;
    threads_ = Threads(nRays);
    if (workers_.size() < size_t(threads_)) workers_.resize(size_t(threads_));
    for (size_t i = 0; i < workers_.size(); ++i) {
        Worker& w = workers_[i];
        w.index = int(i);
        w.pool = this;
        w.store = &store_;
        w.counters = {};
        w.leaves.clear();
        w.listAt = w.listEnd = 0;
        w.nodes.clear();
        w.kept.Clear();
        w.stack.Clear();
    }
    return threads_;
}

Part& WorkerPool::NewPart(uint32_t begin) {
    if (nParts_ == parts_.size()) parts_.emplace_back();
    Part& p = parts_[nParts_++];
    p.begin = begin;
    p.relinked.clear();
    p.newRoot = false;
    p.linkPart = nullptr;
    p.linkNode = kNoNode;
    return p;
}

Part& WorkerPool::Queue(uint32_t begin, TaskBody body) {
    Part& part = NewPart(begin);
    queue_.push_back({&part, std::move(body)});
    return part;
}

int WorkerPool::IdleThreads() {
    std::lock_guard lock(mutex_);
    return threads_ - busy_;
}

void WorkerPool::Run(int threads) {
    OnThreads(threads, [&](int t) { Work(workers_[size_t(t)]); });
}

void WorkerPool::Work(Worker& w) {
    for (;;) {
        Task task;
        {
            std::unique_lock lock(mutex_);
            changed_.wait(lock, [&] { return !queue_.empty() || busy_ == 0; });
            if (queue_.empty()) return;
            task = std::move(queue_.front());
            queue_.pop_front();
            ++busy_;
        }
        RunTask(w, task);
        std::lock_guard lock(mutex_);
        if (--busy_ == 0 && queue_.empty()) changed_.notify_all();
    }
}

void WorkerPool::RunTask(Worker& w, Task& task) {
    Part& part = *task.part;
    w.part = &part;
    part.worker = w.index;
    part.leafBegin = w.leaves.size();
    part.nodeBegin = w.nodes.size();
    if (part.newRoot) w.nodes.push_back(part.root);  // local id kLocal | 0
    task.body(w);
    part.leafEnd = w.leaves.size();
    part.nodeEnd = w.nodes.size();
}

RcCandidate* WorkerPool::ListRoom(Worker& w, size_t n, uint32_t& begin) {
    if (n > w.listEnd - w.listAt) {
        const size_t take = std::max(n, kOutputListChunk);
        size_t at = listsEnd_.load(std::memory_order_relaxed);
        do {
            if (at + take > roomNow_) {
                begin = kOwnList | uint32_t(w.candidates.size());
                w.candidates.resize(w.candidates.size() + n);
                return w.candidates.data() + (begin & ~kOwnList);
            }
        } while (!listsEnd_.compare_exchange_weak(at, at + take, std::memory_order_relaxed));
        if (take == n) {  // a list of a chunk or more: the current chunk stays
            begin = uint32_t(at);
            return lists_ + at;
        }
        w.listAt = at;
        w.listEnd = at + take;
    }
    begin = uint32_t(w.listAt);
    w.listAt += n;
    return lists_ + begin;
}

void WorkerPool::Join(LeafBatch& out, int threads) {
    const size_t listsEnd = listsEnd_.load();
    // Parts in ray order, their nodes appended in that order.
    std::vector<Part*> parts(nParts_);
    for (size_t p = 0; p < nParts_; ++p) parts[p] = &parts_[p];
    std::sort(parts.begin(), parts.end(),
              [](const Part* a, const Part* b) { return a->begin < b->begin; });
    JoinNodes(parts);
    std::vector<PlacedLeaf> leaves = GatherLeaves(parts);
    // Leaves in ray order (their ranges are disjoint and cover rayIndex). Parts that each emit
    // their leaves in ray order (the pinhole's bands) are in it already: no sort to pay.
    const auto byRay = [](const PlacedLeaf& a, const PlacedLeaf& b) {
        return a.leaf.rayBegin < b.leaf.rayBegin;
    };
    if (!std::is_sorted(leaves.begin(), leaves.end(), byRay)) {
        std::sort(leaves.begin(), leaves.end(), byRay);
    }
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
    out.candidates.resize(at);
    listRoom_ = 2 * out.candidates.size();
    if (at == listsEnd) return;
    CopyOwnLists(leaves, ownLeaves, listsEnd, out, threads);
}

void WorkerPool::JoinNodes(const std::vector<Part*>& parts) {
    uint32_t base = uint32_t(store_.size());
    for (Part* part : parts) {
        part->base = base;
        base += uint32_t(part->nodeEnd - part->nodeBegin);
    }
    for (const Part* part : parts) {
        Worker& w = WorkerOf(*part);
        for (size_t i = part->nodeBegin; i < part->nodeEnd; ++i) FixLinks(*part, w.nodes[i]);
        for (uint32_t g : part->relinked) FixLinks(*part, store_[g]);
    }
    for (const Part* part : parts) {
        const Worker& w = WorkerOf(*part);
        store_.insert(store_.end(), w.nodes.begin() + ptrdiff_t(part->nodeBegin),
                      w.nodes.begin() + ptrdiff_t(part->nodeEnd));
    }
    for (const Part* part : parts) {
        if (part->linkNode == kNoNode) continue;
        const uint32_t parent = (part->linkNode & kLocal)
                                    ? part->linkPart->base + (part->linkNode & ~kLocal)
                                    : part->linkNode;
        Link(store_[parent], part->linkField) = part->base;
    }
}

std::vector<WorkerPool::PlacedLeaf> WorkerPool::GatherLeaves(const std::vector<Part*>& parts) {
    size_t n = 0;
    for (const Part* part : parts) n += part->leafEnd - part->leafBegin;
    std::vector<PlacedLeaf> leaves;
    leaves.reserve(n);
    for (const Part* part : parts) {
        Worker& w = WorkerOf(*part);
        for (size_t i = part->leafBegin; i < part->leafEnd; ++i) {
            RcLeaf leaf = w.leaves[i];
            leaf.node = Joined(*part, leaf.node);
            const bool own = (leaf.candBegin & kOwnList) != 0;
            leaves.push_back(
                {leaf, own ? w.candidates.data() + (leaf.candBegin & ~kOwnList) : nullptr});
        }
    }
    return leaves;
}

void WorkerPool::CopyOwnLists(const std::vector<PlacedLeaf>& leaves,
                              const std::vector<uint32_t>& ownLeaves, size_t listsEnd,
                              LeafBatch& out, int threads) {
    const size_t nOwn = out.candidates.size() - listsEnd;
    // Split between the threads at a leaf near the middle of the entries.
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

void WorkerPool::Finish(size_t scratch, BuildCounters& counters) {
    for (Worker& w : workers_) {
        counters.boxTests += w.counters.boxTests;
        counters.rayMoves += w.counters.rayMoves;
        counters.plans += w.counters.plans;
        counters.sharedPlans += w.counters.sharedPlans;
        counters.maxDepth = std::max(counters.maxDepth, w.counters.maxDepth);
        // (The workers' own lists are gone by now: Join frees them.)
        scratch += w.leaves.capacity() * sizeof(RcLeaf) + w.nodes.capacity() * sizeof(Node) +
                   w.stack.Bytes() + w.kept.Bytes();
        w.part = nullptr;
    }
    counters.scratchBytes = scratch;
}

}  // namespace rayclass::classify
