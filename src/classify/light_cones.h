// The candidate lists of the direction cones of the light-cell hierarchy's upper nodes, kept
// across generations. A node of LightCellSubdivision at a given depth covers the same cone of
// directions from its point whatever the rays: its cells' (u, v) range. The list of that cone,
// filtered from the cone above it out to the far side of the scene box, holds every box that any
// node's beam within the cone may reach, so a node may filter from it instead of from its
// parent's list: near the roots, where the parent's list is a face's whole list or most of it,
// that is several times fewer boxes to test. Points found again by the next generation (a point
// light's shadow rays, batch after batch) reuse the lists; each is filtered once, when first
// needed. Each level of cones holds about the scene's boxes once more. Private to the classify
// module.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "core.h"

namespace rayclass::classify {

// A cell's bounds grow by this on each side: (u + 1) rounds by at most 2^-24 for |u| <= 1, so u
// lies at most that far outside the cell its rounded value picks.
constexpr float kCellPad = 1.0f / float(1 << 20);

class LightCones {
  public:
    // Cones down to this depth of a root's hierarchy (each a halving of u or v) keep lists.
    static constexpr int kDepth = 4;

    explicit LightCones(const Core& core) : core_(core) {}

    // Takes the cones of each of `ends`' points from the last generation's point within half the
    // padding of it in every coordinate, or starts new ones; forgets the other points' cones.
    // Not while List runs.
    void Use(const CommonEnds& ends);
    // The list of cone (prefix, depth) of root `root` (point * kFaceCount + face, the points
    // Use took), depth <= kDepth; adds the boxes tested to `boxTests` when it is filtered now.
    // Safe on several threads at once.
    ListView List(uint32_t root, uint32_t prefix, int depth, uint64_t& boxTests);
    size_t Bytes() const;

  private:
    struct Cone {
        std::atomic<bool> ready{false};
        FaceList list;
        size_t n = 0;
    };
    // A point's cones: per face, a binary heap of them (depth d, prefix p at 2^d - 1 + p).
    struct PointCones {
        glm::vec3 point;
        std::unique_ptr<Cone[]> cone[kFaceCount];
    };

    ListView Fill(PointCones& pc, int face, uint32_t prefix, int depth, uint64_t& boxTests);

    const Core& core_;
    std::vector<std::unique_ptr<PointCones>> points_;  // per point of the last Use
    std::mutex mutex_;                                 // taken to filter a list
    FaceList scratch_;
};

}  // namespace rayclass::classify
