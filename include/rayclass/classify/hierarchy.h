// The lazy 5D ray-classification hierarchy (Arvo & Kirk 1987, with the refinements of the
// founding thesis: Haines & Wallace beam tests, distance-sorted candidate lists, shrinking,
// remainder sets and a cost function; see design/lessig-2004-system.md section 2).
//
// Six face roots span the padded scene box and u, v in [-1, 1]. Only nodes that receive rays are
// split, when Subdivide() runs. A split cuts one dimension of a node's rays and shrinks each child
// to the tight 5D bounds of its rays, so children need not cover their parent. Every split node
// therefore owns a remainder: a leaf for the rest of its interval. A later generation routes each
// ray to the child whose interval contains it, else to the remainder, which the cost function may
// split in turn; several batches of rays thus share one hierarchy. (The renderer shares one per
// generation: routing a generation through an earlier one's splits cost more than it saved.)
//
// Candidate lists hold every primitive whose padded box the node's beam may reach (conservative,
// never drops a primitive a ray of the node hits), in the order of the box's near X, which the
// face's presorted array fixes once and filtering keeps. A beam ends where its rays end (their
// tMax, cut at the scene box), so a node's list is first cut at the largest end X of its rays:
// shadow rays' lists stop at the light. A node whose beam would keep most of a long list (checked
// on a sample) passes the list to its children unfiltered instead of copying it. Lists live only
// while a generation is being subdivided: inner lists are scratch on a per-thread stack, leaf
// lists go into the returned LeafBatch.
//
// Near the roots, where a node's rays do not fit the core's cache, a node plans its next levels
// of splits at once (Plan; Params::planRays) so that one pass over its rays does the work of
// several partitions.
//
// Subdivide runs on Params::threads cores. The work is a tree of tasks that depends on the rays
// alone: each face root is a task, and a node with many rays builds its first child itself and
// queues the others (their list is kept until Subdivide returns). A task's leaves and new nodes
// form its part, a range of the arrays of the thread that ran it; parts are joined in ray order,
// so the result is the same for any thread count or timing.
//
// Invariants (checked by tests/classify): every ray that can hit the scene lies in exactly one
// leaf; a node's interval contains the 5D points of the rays that were routed to it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <span>
#include <vector>

#include "rayclass/classify/params.h"
#include "rayclass/classify/ray5d.h"
#include "rayclass/core/scratch_vector.h"
#include "rayclass/scene/scene.h"
#include "rc_types.h"

namespace rayclass::classify {

static_assert(sizeof(RcLeaf) == 32);
static_assert(sizeof(RcCandidate) == 8);

constexpr uint32_t kNoNode = 0xFFFFFFFFu;

// The fixed-point frame of a face's candidate boxes: coordinate c on axis k (X, Y, Z of the face)
// is kept as (c - base[k]) / step in 16 bits, lower bounds rounded down and upper ones up, so a
// stored box contains the padded box. The step is one for all three axes, so beam slopes hold in
// steps as they do in world units. Lists hold 16 bytes a box instead of 28: the filter, which
// mostly copies, then moves less memory.
struct ListFrame {
    float base[3] = {0.0f, 0.0f, 0.0f};
    float step = 1.0f;  // world units per step: the largest extent / 65534, rounded up
};

// The first n entries of a candidate list (structure of arrays in `frame`'s steps, sorted by x0).
struct ListView {
    const uint16_t* x0;
    const uint16_t* x1;
    const uint16_t* y0;
    const uint16_t* y1;
    const uint16_t* z0;
    const uint16_t* z1;
    const uint32_t* prim;
    size_t n;
    const ListFrame* frame;
};

// A node's tight bounds: X, Y, Z, u, v and the end X of its rays (index 5).
struct Bounds6 {
    float lo[kDims + 1];
    float hi[kDims + 1];
    Box5 ToBox5() const;
};

struct Node {
    Box5 box;  // the node's interval: its rays' bounds when it was made
    uint32_t child[2] = {kNoNode, kNoNode};
    uint32_t remainder = kNoNode;  // made when a ray first falls outside both children
    uint8_t face = 0;
    uint8_t depth = 0;
    uint8_t isRemainder = 0;  // a remainder's interval is its parent's minus the children
    bool IsLeaf() const { return child[0] == kNoNode; }
};

// The leaves of one generation in flat arrays, ready to copy into OpenCL buffers.
struct LeafBatch {
    std::vector<RcLeaf> leaves;
    DenseScratchVector<rc_uint> rayIndex;  // leaves' rays, contiguous per leaf
    // Leaves' lists, contiguous per leaf, sorted by nearX, in the order the threads wrote them
    // (with gaps between the chunks they claimed). Scratch: a deep generation's lists (180 MB on
    // sibenik_mirror) are written once, by every thread, and never zeroed first; its capacity
    // is room reserved for the next generation, of which only the pages written are touched.
    DenseScratchVector<RcCandidate> candidates;
    std::vector<rc_uint> missed;          // rays that miss the scene box: answered "no hit"
    uint32_t nRays = 0;                   // rays of the generation (leaf rays + missed)
};

// The bounds of the rays of a range of direction cells (Hierarchy::SubdivideFromEnds): their
// (u, v) cells and their largest end X.
struct CellBox {
    uint8_t uLo, uHi, vLo, vHi;  // in cells; uLo > uHi when no cell holds a ray
    float end;
};

// What a generation's rays ask for: the nearest hit, or any hit (shadow rays).
enum class RayUse : uint8_t { kNearestHit, kAnyHit };

// Counters of the last Subdivide().
struct BuildCounters {
    uint64_t boxTests = 0;      // candidate tests made while filtering lists
    uint64_t rayMoves = 0;      // rays moved by partitions and plans (sum over levels)
    uint64_t fromEnd = 0;       // any-hit rays classified from their common end (CommonEnds)
    uint32_t cellsPerSide = 0;  // the direction grid of SubdivideFromEnds; 0: the general path
    uint32_t plans = 0;         // nodes whose next levels of splits were planned at once
    uint32_t sharedPlans = 0;   // plans whose rays more than one thread moved
    uint32_t maxDepth = 0;      // deepest leaf
    size_t scratchBytes = 0;    // peak bytes of the per-depth list and ray buffers
};

class Hierarchy {
  public:
    Hierarchy(const scene::Scene& scene, const Params& params);

    // Adds rays to the current generation. Several calls append; the generation's ray indices are
    // positions in the concatenation of all rays inserted since the last Subdivide(). The rays
    // are read by Subdivide(), so they must stay alive until it returns. Any-hit rays that end
    // at a common point (CommonEnds: a point light) are classified from there, so their leaves'
    // face is that of -direction: a query cuts a ray's list at the largest X its segment
    // reaches in the leaf's frame, its start or its end.
    void Insert(RayView rays, RayUse use = RayUse::kNearestHit);

    // Routes the generation's rays through the hierarchy, splits where the cost function says so
    // and writes the generation's leaves into `out` (its arrays are reused, so a caller that keeps
    // one LeafBatch per generation slot allocates nothing in steady state). Clears the
    // generation; the nodes stay.
    void Subdivide(LeafBatch& out);
    LeafBatch Subdivide() {
        LeafBatch out;
        Subdivide(out);
        return out;
    }

    // Insert then Subdivide.
    void Classify(RayView rays, LeafBatch& out, RayUse use = RayUse::kNearestHit) {
        Insert(rays, use);
        Subdivide(out);
    }
    LeafBatch Classify(RayView rays, RayUse use = RayUse::kNearestHit) {
        Insert(rays, use);
        return Subdivide();
    }

    // Classifies, as one generation, the eye rays that cl/camera.cl writes for `camera` (float
    // directions, not polar16): ray i is the ray of pixel first + i, for i < n. It splits
    // rectangles of the image instead of moving rays, and reads none: a rectangle's rays share
    // the camera's position, and in a face's frame their slopes u and v are ratios of functions
    // linear in the pixel position, whose extremes over the rectangle lie at its corner pixels.
    // The corners' slopes are taken in double and padded far beyond the kernel's float rounding.
    // A rectangle takes the face of its centre ray once no corner's slope exceeds 1.5 there
    // (slopes above 1 near a face's edge are correct: the beam test and the queries' distance
    // order hold in any frame the rays move forward in). Beams start at the camera, also when
    // it lies outside the scene box. Rays that can reach no primitive (a leaf's whose list is
    // empty; rays from a camera outside the box that miss it) go to `missed`, with no leaf.
    // Splits follow the cost function, halving the longer side (at a multiple of 4
    // pixels, so that a fragment packet spans few rows); a leaf's rays are its rectangle's
    // pixels row by row. Each leaf gets a node of its own that no other links to, so Route()
    // does not find it. Returns false, doing nothing, when the camera lies more than three box
    // sizes outside the scene box (classify its rays with Classify() then), when its basis is
    // degenerate or not finite, when the pixels run past the image, or when the generation
    // holds inserted rays.
    bool ClassifyPinhole(const RcCamera& camera, uint32_t first, uint32_t n, LeafBatch& out);

    // Forgets every split: back to the six face roots (the presorted face lists stay).
    void Reset();

    const std::vector<Node>& Nodes() const { return nodes_; }
    uint32_t FaceRoot(int face) const { return uint32_t(face); }
    // The leaf that routing `r` ends in: the child containing it at every inner node, else the
    // remainder (kNoNode when that remainder does not exist yet).
    uint32_t Route(const Ray5& r) const;
    const BuildCounters& Counters() const { return counters_; }
    const Params& GetParams() const { return params_; }
    const Bounds3f& SceneBox() const { return sceneBox_; }
    // Bytes held now: nodes, presorted face arrays (shared with copies) and reusable scratch.
    size_t MemoryBytes() const;

    // Presorted per-face boxes (structure of arrays, padded, in the face's ListFrame, sorted by
    // x0), and the lists filtered from them.
    struct FaceList {
        ScratchVector<uint16_t> x0, x1, y0, y1, z0, z1;
        ScratchVector<uint32_t> prim;
        size_t Size() const { return prim.size(); }
        size_t Bytes() const { return prim.capacity() * 4 + x0.capacity() * 12; }
        void Resize(size_t n);
    };

    // Candidate lists filtered during a Subdivide, in chunks filled one after another and kept
    // between generations. Used as a stack (a node's list is released when its subtree is
    // built: siblings reuse the memory, which stays in cache) or, for lists that tasks read
    // later, only released when Subdivide returns.
    struct ListArena {
        std::vector<FaceList> chunks;
        size_t chunk = 0, used = 0;
    };

  private:
    static constexpr int kCoords = kDims + 1;
    // Ids of the nodes a task makes, until the tasks' parts are joined: the index in its part
    // with this bit set. kNoNode keeps its meaning (local indices stay far below it); kPending
    // is a link to the root of another task, set when the parts are joined.
    static constexpr uint32_t kLocal = 0x80000000u;
    static constexpr uint32_t kPending = kNoNode - 1;
    // A worker's leaf whose list lies in the worker's own array (candBegin's top bit): the
    // output's room was used up. The output's lists stay below 2^31 entries (16 GiB).
    static constexpr uint32_t kOwnList = 0x80000000u;

    // What one task made: ranges of the arrays of the worker that ran it.
    struct Part {
        uint32_t begin = 0;  // the task's first ray position: parts join in this order
        uint32_t base = 0;   // where its nodes go in nodes_
        int worker = 0;
        size_t leafBegin = 0, leafEnd = 0, nodeBegin = 0, nodeEnd = 0;
        std::vector<uint32_t> relinked;  // earlier nodes whose links now point into the part
        // When the task's root is new: the root (the part's first node) and the node that links
        // to it, in linkPart.
        bool newRoot = false;
        Node root;
        const Part* linkPart = nullptr;
        uint32_t linkNode = kNoNode;
        int linkField = 0;  // 0, 1: child, 2: remainder
    };
    // Levels of midpoint splits planned at once for a node with many rays (Params::planRays):
    // its interval halved up to kPlanLevels times, dimensions chosen as ChooseSplit would on the
    // halves. One bucketing pass puts the rays into the 2^levels cells in order, left before
    // right at every level; the planned nodes then split at cell boundaries without moving a
    // ray, and skip a level whose split leaves one side empty.
    static constexpr int kPlanLevels = 4;
    struct Plan {
        int levels = 0;
        int buf = 0;  // the buffer that holds the cells' rays
        int dim[kPlanLevels];
        float value[(1 << kPlanLevels) - 1];  // plan node h splits at value[h] (heap order)
        uint32_t cellBegin[(1 << kPlanLevels) + 1];
        Bounds6 cell[1 << kPlanLevels];
    };
    // A node inside a plan: its rays are the plan's cells [cellLo, cellHi), split at `level`.
    struct PlanAt {
        const Plan* plan = nullptr;
        int level = 0, cellLo = 0, cellHi = 0;
    };
    // A node of a generation sorted into direction cells (see CellGrid): the cells whose keys
    // start with `prefix`, `depth` bits long, within root `root`.
    struct CellAt {
        uint32_t root = kNoNode;  // end * kFaceCount + face; kNoNode: no cell node
        uint32_t prefix = 0;
        int depth = 0;
    };
    // A ray of a cell that is split further than the grid: its slopes, its end and its id.
    struct CellRay {
        float u, v, end;
        uint32_t id;
    };
    // A subtree to build: a face root, or a later child of a node with many rays.
    struct Task {
        uint32_t node, begin, end;
        int buf;
        Bounds6 tight;
        ListView list;  // the parent's list: a face list or a kept one
        bool reuseList;
        PlanAt plan;
        Part* part;
        CellAt cells;  // a node of the direction cells instead (ProcessCells)
    };
    struct Schedule;  // the task queue of one Subdivide (private to the module)
    // One thread's state while subdividing. The arrays keep their memory between generations.
    struct Worker {
        std::vector<float> keys;
        BuildCounters counters;
        Schedule* schedule = nullptr;
        Part* part = nullptr;  // of the running task
        // What the tasks it ran made, one after another (Part ranges index them). A leaf's
        // candBegin indexes the output's lists, or with kOwnList set the worker's own
        // `candidates`, where lists go once the output's room is claimed.
        std::vector<RcLeaf> leaves;
        ScratchVector<RcCandidate> candidates;
        size_t listAt = 0, listEnd = 0;  // the rest of the chunk of output room it claimed
        std::vector<Node> nodes;
        ListArena stack;                // the lists of the nodes on the path being built
        ListArena kept;                 // lists of nodes whose later children are tasks
        std::deque<Plan> plans;         // this generation's (tasks of any thread may read them)
        std::vector<CellRay> cellRays;  // the rays of the cell being refined (RefineCell)
    };

    // The coordinates of each face's rays that Convert has not stored because all its rays had
    // the same value there (eye rays' origins, unbounded rays' ends): those are never read, and
    // skipping them saves about a third of Convert's memory traffic. Bit k of `mask` is
    // coordinate k; `value` is the first ray's point.
    struct HeldCoords {
        bool seen[kFaceCount] = {};
        unsigned mask[kFaceCount] = {};
        float value[kFaceCount][kCoords];
    };
    // Maps rays (taken from their common ends where `ends` has any) to the 5D buffer; returns
    // how many were taken from an end.
    uint64_t Convert(RayView rays, const CommonEnds& ends, uint32_t firstId, uint32_t* next,
                     Bounds6* faceBounds, HeldCoords& held, std::vector<rc_uint>& missed);
    void Process(Worker& w, uint32_t node, uint32_t begin, uint32_t end, int buf,
                 const Bounds6& tight, const ListView& list, bool reuseList, PlanAt plan);
    void Spawn(Worker& w, uint32_t node, int field, const Box5* newBox, uint32_t begin,
               uint32_t end, int buf, const Bounds6& tight, const ListView& list, bool reuseList,
               PlanAt plan);
    void Work(Worker& w, int index);
    // The schedule's output room and the workers' state for a generation of nRays rays; returns
    // the number of threads to run.
    int StartWorkers(Schedule& schedule, uint32_t nRays, LeafBatch& out);
    // Sums the workers' counters (scratch: the bytes of the generation's ray buffers) and ends
    // the generation.
    void FinishWorkers(size_t scratch);
    // ClassifyPinhole's subdivision of image rectangle `rect` (pixels x0 <= x < x1, y0 <= y <
    // y1) within the frame of `face` and `list`, or of no face yet (face < 0); its leaves' rays
    // go to rayOut_ from `slot` on, the rays that reach no primitive to `missed`.
    struct Pinhole;  // the camera in double (pinhole.cpp)
    struct PixelRect {
        uint32_t x0, y0, x1, y1;
    };
    void ProcessRect(Worker& w, const Pinhole& cam, const PixelRect& rect, int face, int depth,
                     const ListView* list, uint32_t& slot, std::vector<rc_uint>& missed);
    // Moves the rays [begin, end) of buffer `buf` into the other one by the child of an earlier
    // split whose interval contains them: box0's, else box1's, else the remainder (groups 0, 1,
    // 2, each in ray order, one after the other); count[g] gets each group's size.
    void RouteRays(int face, const Box5& box0, const Box5& box1, int buf, uint32_t begin,
                   uint32_t end, uint32_t count[3]);
    void EmitLeaf(Worker& w, uint32_t node, uint32_t begin, uint32_t end, int buf,
                  const ListView& list, float endHi);
    // Adds `leaf` (its rays placed already) with the list of `node`, cut at endHi.
    void PushLeaf(Worker& w, RcLeaf leaf, uint32_t node, const ListView& list, float endHi);
    // Room for a list of n entries: sets `begin` to where it lies (see Worker::leaves).
    RcCandidate* ListRoom(Worker& w, size_t n, uint32_t& begin);
    ListView Filter(Worker& w, const Bounds6& tight, const ListView& list, bool keep);
    bool ChooseSplit(const Node& node, const Bounds6& tight, uint32_t nRays, const ListView& list,
                     int& dim) const;
    // The dimension to split by the extents of a node's interval (-1: none is long enough).
    int SplitDim(int face, const float* extent) const;
    // Plans the splits of a node's rays from `dim` on and buckets the rays into the plan's
    // cells (in the other buffer).
    const Plan& MakePlan(Worker& w, int face, int dim, int buf, uint32_t begin, uint32_t end,
                         const Bounds6& tight);
    // The next planned split of a node at `at` with rays [begin, end): the left child's rays
    // are [begin, split). False when every level left would leave one side empty.
    bool PlannedSplit(const PlanAt& at, uint32_t begin, uint32_t end, uint32_t& split,
                      Bounds6 childBox[2], PlanAt childAt[2]) const;
    Bounds6 Bounds(int face, int buf, uint32_t begin, uint32_t end) const;
    // Any-hit rays that all end at common points (point lights) classified from there without
    // moving them level by level (light_cells.cpp): one counting sort puts the rays in order of
    // a key, the point, the face of the direction from it and the (u, v) cell of a grid of
    // 2^bits x 2^bits on that face, the cell's bits interleaved (u's first), so that every
    // halving of a cell range, u and v in turn, leaves two ranges of keys and of rays. The
    // hierarchy is the binary tree of those halvings, split by the cost function; a node's
    // bounds come from a pyramid of the cells' (u, v) ranges and largest ends, so no node reads
    // a ray (below a single cell, RefineCell reads them). Each leaf gets a node of its own that
    // no other links to, as ClassifyPinhole's do. Returns false, doing nothing, when the
    // generation is not such rays.
    bool SubdivideFromEnds(LeafBatch& out);
    // The keys of `rays` (kNoNode for a ray that misses) and each cell's count and largest end,
    // added to `count` and `end`; the misses go to `missed`. False when a ray neither ends at one
    // of the points nor misses (the generation then takes Subdivide's general path).
    bool CellKeys(RayView rays, const CommonEnds& ends, uint32_t firstId, uint32_t* keys,
                  uint32_t* count, float* end, std::vector<rc_uint>& missed,
                  uint64_t& fromEnd) const;
    void ProcessCells(Worker& w, CellAt at, const ListView& list, bool reuseList);
    // A single cell whose rays the cost function splits further: its rays, read again, are
    // split ray by ray (midpoints of their tight (u, v) bounds) below the grid.
    void RefineCell(Worker& w, uint32_t root, uint32_t begin, uint32_t n, int depth,
                    const ListView& list);
    // Rays [0, n) of `rays`, whose ids go to the output from `slot` on.
    void ProcessCellRays(Worker& w, uint32_t root, CellRay* rays, uint32_t n, uint32_t slot,
                         int depth, const ListView& list, bool reuseList);
    void SpawnCells(Worker& w, const CellAt& at, const ListView& list, bool reuseList);
    Bounds6 CellBounds(const CellAt& at) const;
    // Sets the coordinates that do not vary among the face's rays to their value.
    void SetConstants(int face, Bounds6& b) const;
    float SplitValue(Worker& w, int dim, int buf, uint32_t begin, uint32_t end,
                     const Bounds6& tight);
    // Where a split leaves a node's rays: in buffer `buf`, the child whose rays come first in
    // [begin, mid) (the left one, key < value, when leftFirst), the other in [mid, end).
    struct Split {
        uint32_t mid;
        int buf;
        bool leftFirst;
    };
    Split Partition(Worker& w, int face, int dim, float value, int buf, uint32_t begin,
                    uint32_t end, Bounds6& left, Bounds6& right);
    uint32_t NewNode(Worker& w, const Box5& box, int face, int depth, bool isRemainder);
    Node& At(Worker& w, uint32_t id) {
        return (id & kLocal) ? w.nodes[w.part->nodeBegin + (id & ~kLocal)] : nodes_[id];
    }
    // Maps the generation's rays into buffer 0: face f's rays are [faceBegin[f], faceEnd[f]).
    void ConvertAll(uint32_t* faceBegin, uint32_t* faceEnd, Bounds6* faceBounds, LeafBatch& out);
    // Joins the tasks' parts into `out` (whose rayIndex the leaves have filled, and whose lists
    // the first `listsEnd` entries of out.candidates hold, bar the workers' own).
    // `threads`: the generation's (StartWorkers'), which copy the lists that went to the
    // workers' own arrays.
    void Join(LeafBatch& out, size_t listsEnd, int threads);
    Part& NewPart(uint32_t begin);
    // Nodes with more rays than this hand their later children to the task queue.
    uint32_t TaskCut(uint32_t nRays) const;
    int Threads(uint32_t nRays) const;

    const scene::Scene& scene_;
    Params params_;
    Bounds3f sceneBox_;
    std::array<float, kDims> rootExtent_[kFaceCount];
    std::vector<Node> nodes_;
    // Read-only once built: copies of a hierarchy share them.
    std::shared_ptr<const std::array<FaceList, kFaceCount>> faceLists_;
    ListFrame listFrame_[kFaceCount];

    // The current generation: the inserted rays, and their 5D points by face in two ping-pong
    // buffers of structure-of-arrays: X, Y, Z, u, v and the X where the ray ends (its start's X
    // plus its reach, which cuts beams: shadow rays end at the light). Of n inserted rays, face
    // f's lie at the start of the slab [f n, (f + 1) n) (see ConvertAll).
    struct Inserted {
        RayView rays;
        CommonEnds ends;  // none for nearest-hit rays
    };
    std::vector<Inserted> inserted_;
    uint32_t nInserted_ = 0;
    ScratchVector<float> coord_[2][kCoords];
    ScratchVector<uint32_t> id_[2];
    ScratchVector<uint32_t> dest_;
    // Where the leaves' ray ids go: the output's rayIndex, face after face, so that a buffer
    // position p of face f lands at p + rayShift_[f] (modulo 2^32) in ray order.
    rc_uint* rayOut_ = nullptr;
    uint32_t rayShift_[kFaceCount] = {};
    // Per face: coordinates that vary among its rays, and the value of those that do not.
    bool active_[kFaceCount][kCoords] = {};
    float constant_[kFaceCount][kCoords] = {};
    // The direction cells of the last SubdivideFromEnds: the grid, and per root (point and face)
    // a pyramid of the (u, v) ranges of the non-empty cells under each node of its quadtree,
    // level after level from the root (1, 4, 16, ... entries; level q's index is a key's top
    // 2q bits), with the largest end of their rays.
    struct CellGrid {
        int bits = 0;
        uint32_t roots = 0;
        RayView rays;                                    // the generation's
        CommonEnds ends;                                 // and their points
        float origin[CommonEnds::kMax * kFaceCount][3];  // each root's point in its face's frame
        ScratchVector<uint32_t> key;                     // per ray
        std::vector<ScratchVector<uint32_t>> count;      // per piece and cell, then positions
        std::vector<ScratchVector<float>> end;           // per piece and cell: the largest end
        // Per root, each cell's first position in the root, then the root's size.
        ScratchVector<uint32_t> begin;
        std::vector<uint32_t> rootBegin;  // per root, its first position; then the total
        ScratchVector<CellBox> box;       // the roots' pyramids, one after another
    };
    CellGrid cells_;
    // Scratch kept between generations so that steady state allocates nothing.
    std::vector<Worker> workers_;
    std::deque<Part> parts_;  // the first nParts_ belong to this generation's tasks
    size_t nParts_ = 0;
    // Output room for the next generation's lists: twice the last one's (a mirror generation's
    // lists grow 1.3-1.6x over the one before on sibenik_mirror).
    size_t listRoom_ = 0;
    BuildCounters counters_;
};

}  // namespace rayclass::classify
