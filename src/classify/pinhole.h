// The eye-ray strategy: the rays of a pinhole camera classified by rectangles of the image, not
// ray by ray. A rectangle's rays share the camera's position, and in a face's frame their slopes
// u and v are ratios of functions linear in the pixel position, whose extremes over the rectangle
// lie at its corner pixels: a rectangle's bounds come from four rays, taken in double and padded
// far beyond the kernel's float rounding, and no ray is read or moved. Splits follow the cost
// function, halving the longer side. Private to the classify module.
#pragma once

#include <cstdint>
#include <vector>

#include "core.h"

namespace rayclass::classify {

class PinholeSubdivision {
  public:
    explicit PinholeSubdivision(Core& core) : core_(core) {}

    // Classifies the eye rays of pixels [first, first + n) of `camera` into `out` (see
    // Hierarchy::ClassifyPinhole); false, doing nothing, when the camera does not allow it.
    bool Classify(const RcCamera& camera, uint32_t first, uint32_t n, LeafBatch& out);

  private:
    struct Camera;  // the camera in double (pinhole.cpp)
    // Pixels x0 <= x < x1, y0 <= y < y1.
    struct PixelRect {
        uint32_t x0, y0, x1, y1;
    };
    // Where a rectangle's leaves go: its rays' ids from `slot` on, the rays that reach no
    // primitive to `missed`.
    struct RectOut {
        uint32_t slot;
        std::vector<rc_uint> missed;
    };
    // Which of a leaf's rays can reach its candidates: all, none, or some (from a camera outside
    // the scene box, a leaf on the box's outline: each ray is tested).
    enum class Reach { kAll, kNone, kSome };
    // The slopes (u, v) in a face's frame of a rectangle's corner rays, [row][column]: top and
    // bottom row, left and right column.
    struct Corners {
        double slope[2][2][2];
    };

    // Classifies the rays of the camera's batch in bands of rows on the worker pool.
    void ClassifyBands(const Camera& cam, LeafBatch& out);
    // A rectangle's rays and beam, and its list: the entries the beam may reach or, when the
    // beam would keep most of it (not filtered), its parent's list cut at the rays' end.
    struct RectBeam {
        uint32_t nRays;
        Bounds6 tight;
        Corners corners;
        ListView own;
        bool filtered;
    };

    // The subdivision of `rect` in the frame of the face its centre ray looks at, from that
    // face's whole list; a rectangle too wide for one frame halves first.
    void ProcessRect(Worker& w, const Camera& cam, const PixelRect& rect, int depth, RectOut& out);
    // The node of `rect` (of `face`, its parent's list `list`) with its beam and list: halves or
    // a leaf.
    void ProcessNode(Worker& w, const Camera& cam, const PixelRect& rect, int face, int depth,
                     const ListView& list, const RectBeam& beam, RectOut& out);
    // The halves of `rect` (of `face`, its corners' slopes `corners`, list `list`): where both
    // filter the list, in one pass.
    void SplitRect(Worker& w, const Camera& cam, const PixelRect& rect, const Corners& corners,
                   int face, int depth, const ListView& list, RectOut& out);
    // A leaf of node `node`, `rect`'s rays that can reach a primitive with list `own`.
    void EmitRect(Worker& w, const Camera& cam, const PixelRect& rect, const Node& node,
                  const ListView& own, float endHi, Reach reach, RectOut& out);

    Core& core_;
    rc_uint* rayOut_ = nullptr;  // the output's rayIndex, during Classify
};

}  // namespace rayclass::classify
