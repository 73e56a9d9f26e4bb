// The general classification strategy: any generation of rays, subdivided ray by ray.
//
// The rays are mapped to their 5D points (convert.h), face by face, into two ping-pong buffers of
// structure of arrays: X, Y, Z, u, v and the X where the ray ends (its start's X plus its reach,
// which cuts beams: shadow rays end at the light). A node the cost function splits partitions
// its rays at the midpoint (or median) of its longest relative extent and shrinks each child to
// the tight bounds of its rays, so children need not cover their parent; every split node
// therefore owns a remainder, a leaf for the rest of its interval. A later generation routes each
// ray to the child whose interval contains it, else to the remainder, which the cost function
// may split in turn. Near the roots, where a node's rays do not fit the core's cache, a node plans
// its next levels of splits at once (Params::planRays), so that one pass over its rays does the
// work of several partitions. Private to the classify module.
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

#include "core.h"

namespace rayclass::classify {

struct ConvertPiece;  // a thread's share of a generation's conversion (ray_subdivision.cpp)

class RaySubdivision {
  public:
    explicit RaySubdivision(Core& core) : core_(core) {}

    // Routes `gen`'s rays through the hierarchy, splits where the cost function says so and
    // writes the leaves into `out` (its leaves and missed rays cleared, nRays set).
    void Classify(const Generation& gen, LeafBatch& out);

  private:
    // Levels of midpoint splits planned at once for a node with many rays: its interval halved
    // up to kPlanLevels times, dimensions chosen as the cost function would on the halves. One
    // bucketing pass puts the rays into the 2^levels cells in order, left before right at every
    // level; the planned nodes then split at cell boundaries without moving a ray, and skip a
    // level whose split leaves one side empty.
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
    // A node's rays: positions [begin, end) of buffer `buf`, their tight bounds, the list they
    // start from (the parent's; with reuseList not to be filtered again) and their plan.
    struct NodeRays {
        uint32_t begin, end;
        int buf;
        Bounds6 tight;
        ListView list;
        bool reuseList;
        PlanAt plan;
    };
    // Where a split leaves a node's rays: in buffer `buf`, the child whose rays come first in
    // [begin, mid) (the left one, key < value, when leftFirst), the other in [mid, end).
    struct Split {
        uint32_t mid;
        int buf;
        bool leftFirst;
    };
    // A worker's scratch of this strategy, kept between generations.
    struct Scratch {
        std::vector<float> keys;
        std::deque<Plan> plans;  // this generation's (tasks of any thread may read them)
    };

    // Maps the generation's rays into buffer 0: face f's rays are [faceBegin[f], faceEnd[f]).
    void ConvertAll(const Generation& gen, uint32_t* faceBegin, uint32_t* faceEnd,
                    Bounds6* faceBounds, LeafBatch& out);
    // Gives the coordinates that pieces held back but that vary over their face their value.
    void ReleaseHeld(const std::vector<ConvertPiece>& pieces, const Bounds6* faceBounds);
    // Moves the pieces' runs of every face down to follow each other from faceBegin.
    void CloseUpFaces(const std::vector<ConvertPiece>& pieces, const uint32_t* faceBegin,
                      const Bounds6* faceBounds, int threads);
    // Whether coordinate k varies among face f's rays, and the value of those that do not.
    void FindConstants(const Bounds6* faceBounds);
    // Builds the subtree of `node`.
    void Process(Worker& w, uint32_t node, const NodeRays& rays);
    // A node split by an earlier generation: its rays routed to its children and remainder.
    void ProcessSplit(Worker& w, uint32_t node, const NodeRays& rays);
    // Splits the rays of a leaf the cost function splits; false when it leaves one side empty.
    bool SplitRays(Worker& w, const Node& node, const NodeRays& rays, const ListView& own,
                   Split& split, Bounds6 childBox[2], PlanAt childAt[2]);
    // Queues the subtree of `node`'s child or remainder `field` (a new one with box `newBox`).
    void Spawn(Worker& w, uint32_t node, int field, const Box5* newBox, const NodeRays& rays);
    // Moves the rays [begin, end) of buffer `buf` into the other one by the child of an earlier
    // split whose interval contains them: box0's, else box1's, else the remainder (groups 0, 1,
    // 2, each in ray order, one after the other); count[g] gets each group's size.
    void RouteRays(int face, const Box5& box0, const Box5& box1, int buf, uint32_t begin,
                   uint32_t end, uint32_t count[3]);
    void EmitLeaf(Worker& w, uint32_t node, const NodeRays& rays, const ListView& list);
    float SplitValue(Worker& w, int dim, const NodeRays& rays);
    Split Partition(Worker& w, int face, int dim, float value, const NodeRays& rays, Bounds6& left,
                    Bounds6& right);
    // Plans the splits of a node's rays from `dim` on and buckets the rays into the plan's
    // cells (in the other buffer).
    const Plan& MakePlan(Worker& w, int face, int dim, const NodeRays& rays);
    // The next planned split of a node at `at` with rays [begin, end): the left child's rays
    // are [begin, split). False when every level left would leave one side empty.
    bool PlannedSplit(const PlanAt& at, uint32_t begin, uint32_t end, uint32_t& split,
                      Bounds6 childBox[2], PlanAt childAt[2]) const;
    Bounds6 Bounds(int face, int buf, uint32_t begin, uint32_t end) const;
    // Sets the coordinates that do not vary among the face's rays to their value.
    void SetConstants(int face, Bounds6& b) const;

    Core& core_;
    // The generation's 5D points by face in two ping-pong buffers. Of n rays, face f's lie at
    // the start of the slab [f n, (f + 1) n) (see ConvertAll).
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
    std::vector<Scratch> scratch_;  // per worker
};

}  // namespace rayclass::classify
