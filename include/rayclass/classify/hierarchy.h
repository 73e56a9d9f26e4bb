// The lazy 5D ray-classification hierarchy (Arvo & Kirk 1987, with the refinements of the
// founding thesis: beam tests, distance-sorted candidate lists, shrinking, remainder sets and a
// cost function; docs/design.md explains them).
//
// Six face roots span the padded scene box and u, v in [-1, 1]. Rays are classified a generation
// at a time: only nodes that receive rays are split, where the cost function says so. A split
// shrinks each child to the tight 5D bounds of its rays, so children need not cover their parent,
// and every split node owns a remainder, a leaf for the rest of its interval. A later generation
// routes each ray to the child whose interval contains it, else to the remainder; several batches
// of rays thus share one hierarchy.
//
// A leaf's candidate list holds every primitive whose padded box the leaf's beam may reach (never
// one fewer than its rays hit), in the order of the box's near X. A beam ends where its rays end
// (their tMax, cut at the scene box), so shadow rays' lists stop at the light.
//
// Which strategy classifies a generation is the hierarchy's choice: eye rays of a pinhole camera
// by rectangles of the image (ClassifyPinhole), shadow rays to point lights by cells of their
// direction from the light, any other rays ray by ray. Classification runs on Params::threads
// cores, and its result is the same for any thread count.
//
// Invariants (checked by tests/classify): every ray that can hit the scene lies in exactly one
// leaf; a node's interval contains the 5D points of the rays that were routed to it.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
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
    // (with gaps between the chunks they claimed). Scratch: a deep generation's lists are large,
    // written once, by every thread, and never zeroed first; its capacity is room reserved for
    // the next generation, of which only the pages written are touched.
    DenseScratchVector<RcCandidate> candidates;
    std::vector<rc_uint> missed;  // rays that miss the scene box: answered "no hit"
    uint32_t nRays = 0;           // rays of the generation (leaf rays + missed)
};

// What a generation's rays ask for: the nearest hit, or any hit (shadow rays).
enum class RayUse : uint8_t { kNearestHit, kAnyHit };

// Counters of the last classification.
struct BuildCounters {
    uint64_t boxTests = 0;      // candidate tests made while filtering lists
    uint64_t rayMoves = 0;      // rays moved by partitions and plans (sum over levels)
    uint64_t fromEnd = 0;       // any-hit rays classified from their common end (CommonEnds)
    uint32_t cellsPerSide = 0;  // the direction grid of shadow rays; 0: not used
    uint32_t plans = 0;         // nodes whose next levels of splits were planned at once
    uint32_t sharedPlans = 0;   // plans whose rays more than one thread moved
    uint32_t maxDepth = 0;      // deepest leaf
    size_t scratchBytes = 0;    // peak bytes of the per-depth list and ray buffers
};

class Hierarchy {
  public:
    Hierarchy(const scene::Scene& scene, const Params& params);
    // A hierarchy with `other`'s nodes that shares its presorted candidate lists.
    Hierarchy(const Hierarchy& other);
    Hierarchy& operator=(const Hierarchy&) = delete;
    ~Hierarchy();

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
    LeafBatch Subdivide();

    // Insert then Subdivide.
    void Classify(RayView rays, LeafBatch& out, RayUse use = RayUse::kNearestHit);
    LeafBatch Classify(RayView rays, RayUse use = RayUse::kNearestHit);

    // Classifies, as one generation, the eye rays that cl/camera.cl writes for `camera` (float
    // directions, not polar16): ray i is the ray of pixel first + i, for i < n. No ray is read.
    // Beams start at the camera, also when it lies outside the scene box. Rays that can reach no
    // primitive (a leaf's whose list is empty; rays from a camera outside the box that miss it)
    // go to `missed`, with no leaf. A leaf's rays are its rectangle's pixels row by row, and each
    // leaf gets a node of its own that no other links to, so Route() does not find it. Returns
    // false, doing nothing, when the camera lies more than three box sizes outside the scene box
    // (classify its rays with Classify() then), when its basis is degenerate or not finite, when
    // the pixels run past the image, or when the generation holds inserted rays.
    bool ClassifyPinhole(const RcCamera& camera, uint32_t first, uint32_t n, LeafBatch& out);

    // Forgets every split: back to the six face roots (the presorted face lists stay).
    void Reset();

    const std::vector<Node>& Nodes() const;
    uint32_t FaceRoot(int face) const { return uint32_t(face); }
    // The leaf that routing `r` ends in: the child containing it at every inner node, else the
    // remainder (kNoNode when that remainder does not exist yet).
    uint32_t Route(const Ray5& r) const;
    const BuildCounters& Counters() const;
    const Params& GetParams() const;
    const Bounds3f& SceneBox() const;
    // Bytes held now: nodes, presorted face arrays (shared with copies) and reusable scratch.
    size_t MemoryBytes() const;

  private:
    struct Impl;  // the shared core and the strategies (src/classify)
    std::unique_ptr<Impl> impl_;
};

}  // namespace rayclass::classify
