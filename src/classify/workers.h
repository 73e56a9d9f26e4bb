// The worker pool that classifies a generation on Params::threads cores, whichever strategy
// splits it. The work is a tree of tasks that depends on the rays alone: a strategy queues its
// roots, and a node with many rays builds its first child itself and queues the others (their
// list is kept until the generation is done). A task's leaves and new nodes form its part, a
// range of the arrays of the worker that ran it; parts are joined in ray order, so the result is
// the same for any thread count or timing. Private to the classify module.
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <vector>

#include "list_arena.h"
#include "lists.h"
#include "rayclass/classify/hierarchy.h"
#include "support.h"

namespace rayclass::classify {

// Ids of the nodes a task makes, until the tasks' parts are joined: the index in its part with
// this bit set. kNoNode keeps its meaning (local indices stay far below it); kPending is a link
// to the root of another task, set when the parts are joined.
constexpr uint32_t kLocal = 0x80000000u;
constexpr uint32_t kPending = kNoNode - 1;

// The link of `n` that `field` names: 0 and 1 the children, 2 the remainder.
inline uint32_t& Link(Node& n, int field) { return field < 2 ? n.child[field] : n.remainder; }

// What one task made: ranges of the arrays of the worker that ran it.
struct Part {
    uint32_t begin = 0;  // the task's first ray position: parts join in this order
    uint32_t base = 0;   // where its nodes go in the node store
    int worker = 0;
    size_t leafBegin = 0, leafEnd = 0, nodeBegin = 0, nodeEnd = 0;
    std::vector<uint32_t> relinked;  // earlier nodes whose links now point into the part
    // When the task's root is new: the root (the part's first node) and the node that links to
    // it, in linkPart.
    bool newRoot = false;
    Node root;
    const Part* linkPart = nullptr;
    uint32_t linkNode = kNoNode;
    int linkField = 0;  // see Link
};

class WorkerPool;

// One thread's state while classifying. The arrays keep their memory between generations.
struct Worker {
    int index = 0;
    WorkerPool* pool = nullptr;
    std::vector<Node>* store = nullptr;  // the hierarchy's nodes
    BuildCounters counters;
    Part* part = nullptr;  // of the running task
    // What the tasks it ran made, one after another (Part ranges index them). A leaf's candBegin
    // indexes the output's lists, or with kOwnList set the worker's own `candidates`, where lists
    // go once the output's room is claimed.
    std::vector<RcLeaf> leaves;
    ScratchVector<RcCandidate> candidates;
    size_t listAt = 0, listEnd = 0;  // the rest of the chunk of output room it claimed
    std::vector<Node> nodes;
    ListArena stack;  // the lists of the nodes on the path being built
    ListArena kept;   // lists of nodes whose later children are tasks

    // Node `id`: one of the store's, or with kLocal set one this task made.
    Node& At(uint32_t id) {
        return (id & kLocal) ? nodes[part->nodeBegin + (id & ~kLocal)] : (*store)[id];
    }
    uint32_t NewNode(const Box5& box, int face, int depth, bool isRemainder);
    // The entries of `list` the beam of `tight` may reach, on the stack, or with `keep` where
    // queued tasks can read them.
    ListView Filter(const Bounds6& tight, const ListView& list, bool keep) {
        return FilterOnto(keep ? kept : stack, tight, list, counters.boxTests);
    }
    // Adds `leaf` (its rays placed already) with the list of `node`, cut at endHi.
    void PushLeaf(RcLeaf leaf, uint32_t node, const ListView& list, float endHi);
};

// The body of a task: builds a subtree on the worker that runs it.
using TaskBody = std::function<void(Worker&)>;

class WorkerPool {
  public:
    WorkerPool(std::vector<Node>& store, const Params& params);
    WorkerPool(const WorkerPool&) = delete;
    WorkerPool& operator=(const WorkerPool&) = delete;

    // Threads that classify a generation of nRays rays.
    int Threads(uint32_t nRays) const;
    // Nodes with more rays than this hand their later children to the task queue.
    uint32_t TaskCut(uint32_t nRays) const;

    // Begins a generation of nRays rays whose leaves go to `out`, nodes with more than `cut`
    // rays queueing their later children. Returns the number of threads to run.
    int Start(uint32_t nRays, uint32_t cut, LeafBatch& out);
    // Queues a task whose rays start at position `begin`, before Run.
    Part& Queue(uint32_t begin, TaskBody body);
    // Queues a task from inside another: `prepare(part)` runs under the queue's lock, where it
    // may link the new part's root to its parent, and returns the task's body.
    template <typename Prepare>
    void Spawn(uint32_t begin, Prepare&& prepare) {
        {
            std::lock_guard lock(mutex_);
            Part& part = NewPart(begin);
            queue_.push_back({&part, prepare(part)});
        }
        changed_.notify_one();
    }
    // Runs the queue on `threads` threads until it is empty and no task runs.
    void Run(int threads);
    // Joins the parts into `out` (whose rayIndex the leaves have filled) and the node store.
    // `threads`: the generation's, which copy the lists that went to the workers' own arrays.
    void Join(LeafBatch& out, int threads);
    // Sums the workers' counters into `counters`, with `scratch` bytes of the strategy's own.
    void Finish(size_t scratch, BuildCounters& counters);

    uint32_t Cut() const { return cut_; }
    // Threads waiting for work now.
    int IdleThreads();
    Worker& WorkerOf(const Part& part) { return workers_[size_t(part.worker)]; }
    // Room for a list of n entries: sets `begin` to where it lies (see Worker::leaves).
    RcCandidate* ListRoom(Worker& w, size_t n, uint32_t& begin);

  private:
    struct Task {
        Part* part;
        TaskBody body;
    };
    // A leaf being joined, with its list when that lies in its worker's own array.
    struct PlacedLeaf {
        RcLeaf leaf;
        const RcCandidate* own;
    };
    Part& NewPart(uint32_t begin);
    void Work(Worker& w);
    void RunTask(Worker& w, Task& task);
    // The parts' nodes appended to the store (`parts` in ray order), their links joined.
    void JoinNodes(const std::vector<Part*>& parts);
    std::vector<PlacedLeaf> GatherLeaves(const std::vector<Part*>& parts);
    // Copies the lists of `ownLeaves` (indices into `leaves` and out.leaves, whose candBegin is
    // set) from the workers' arrays to out.candidates, after the first listsEnd entries.
    void CopyOwnLists(const std::vector<PlacedLeaf>& leaves, const std::vector<uint32_t>& ownLeaves,
                      size_t listsEnd, LeafBatch& out, int threads);

    std::vector<Node>& store_;
    const Params& params_;
    std::vector<Worker> workers_;
    std::deque<Part> parts_;  // the first nParts_ belong to this generation's tasks
    size_t nParts_ = 0;
    // Output room for the next generation's lists: twice the last one's (a mirror generation's
    // lists grow over the one before).
    size_t listRoom_ = 0;

    // The generation's task queue.
    std::mutex mutex_;
    std::condition_variable changed_;
    std::deque<Task> queue_;
    int threads_ = 1;
    int busy_ = 0;  // threads inside a task
    uint32_t cut_ = kNoNode;
    // The output's lists: room for `roomNow_` entries, of which [0, listsEnd_) are claimed.
    RcCandidate* lists_ = nullptr;
    size_t roomNow_ = 0;
    std::atomic<size_t> listsEnd_{0};
};

}  // namespace rayclass::classify
