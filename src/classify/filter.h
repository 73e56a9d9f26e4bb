// The candidate lists' fixed-point frame, and the conservative test of a hypercube's beam against
// padded primitive boxes with the list filter built on it. Private to the classify module.
//
// Haines & Wallace ("Shaft Culling for Efficient Ray-Traced Radiosity", 1994, after the beam
// tests of their ray classification) test a box against each side of the beam polyhedron at the
// corner the side's slope picks. With origins O = [x0,x1]x[y0,y1]x[z0,z1] and slopes
// U = [u0,u1], V = [v0,v1], a point of box B is reachable iff B - O (a box [a0,a1]x[c0,c1]x[e0,e1]
// with a0 = X0 - x1, a1 = X1 - x0, c0 = Y0 - y1, ...) meets s (1, u, v) for some s >= 0. The four
// sides give u1 s >= c0, u0 s <= c1, v1 s >= e0, v0 s <= e1: each is the side's corner test, and
// the sign of the side's slope decides whether it bounds s from below or above. Coupling them
// through one s (intersecting the four half-lines with [max(a0, 0), min(a1, reach)]) is exact for
// "box meets beam" in real arithmetic and rejects more than testing the two projections apart.
// Zero slope bounds are widened to +-1e-30, which keeps the test conservative and finite.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "lists.h"
#include "rc_types.h"
#include "support.h"

namespace rayclass::classify {

// The frame of boxes within [lo, hi] (X, Y, Z of a face; the default frame when lo > hi).
ListFrame MakeListFrame(const float lo[3], const float hi[3]);

// World coordinate c on `axis` in steps, unrounded (double: exact enough for either rounding).
inline double ToSteps(const ListFrame& f, int axis, float c) {
    return (double(c) - double(f.base[axis])) / double(f.step);
}

// The stored bounds of box [lo, hi] on `axis` of `frame`: steps rounded outwards (double
// arithmetic, so that lo >= base and hi <= base + 65534 step map into 16 bits). Inline: the
// hierarchy's set-up calls them six times for every primitive and face.
inline uint16_t StepsBelow(const ListFrame& frame, int axis, float lo) {
    return uint16_t(std::clamp(std::floor(ToSteps(frame, axis, lo)), 0.0, 65535.0));
}
inline uint16_t StepsAbove(const ListFrame& frame, int axis, float hi) {
    return uint16_t(std::clamp(std::ceil(ToSteps(frame, axis, hi)), 0.0, 65535.0));
}
// Writes the boxes boxes[order[i]] of `face` (world boxes, padded) for i < n into `out`, in
// `frame`'s steps (StepsBelow and StepsAbove, bit for bit), with order[i] as the primitive.
void FillFaceList(int face, const ListFrame& frame, const Bounds3f* boxes, const uint32_t* order,
                  size_t n, const ListOut& out);
// The world coordinate of `steps` on `axis` (the near X of a leaf's candidate), never above a
// float bound that StepsBelow took there: that rounded down, so the exact value lies at or below
// the bound, and the fused multiply-add rounds the exact value once, to the nearest float.
inline float WorldBelow(const ListFrame& frame, int axis, uint16_t steps) {
    return std::fma(float(steps), frame.step, frame.base[axis]);
}
// The first n entries of `list` as a leaf's candidates: each primitive with the world X its box
// starts at (WorldBelow).
void WriteCandidates(const ListView& list, size_t n, RcCandidate* out);
// The number of the first n entries of `list` whose near X is at most `endHi` (world units; the
// list is sorted by it): never fewer than hold a box that starts before endHi.
size_t CountUpTo(const ListView& list, float endHi);

// The list up to the end X of a node's rays (tight.hi[kDims]).
ListView CutAtEnd(const Bounds6& tight, const ListView& list);
// Whether the beam of `tight` would keep most of a long list (on a sample of it): such a list is
// not worth copying.
bool KeepsMost(const Bounds6& tight, const ListView& list);

// A beam in `frame`'s steps (x0 .. z1 grown by a rounding margin, reach in steps).
struct BeamTest {
    float x0, x1, y0, y1, z0, z1;
    float ru1, ru0, rv1, rv0;  // reciprocals of the (widened) slope bounds
    float reach;               // how far along X any ray of the beam travels
    int signs;                 // bit 0: u1 > 0, 1: u0 > 0, 2: v1 > 0, 3: v0 > 0
};

// The test of `box` (world units of the face) whose rays travel at most `reach` along X.
BeamTest MakeBeamTest(const ListFrame& frame, const Box5& box, float reach);

// Scalar form of the test on a box in steps, for tests and as the reference of the vector filter.
bool BeamMayReach(const BeamTest& t, float bx0, float bx1, float by0, float by1, float bz0,
                  float bz1);

// The boxes of the blocks of `list` (see ListBlocks), as the first BlockCount(list.n) entries of
// `out` (prim untouched).
void FillBlocks(const ListView& list, const ListOut& out);
// Whether the filter reads lists' block summaries: the vector filter skips the blocks a beam
// cannot reach, the generic loop tests every entry.
bool FilterSkipsBlocks();

// Keeps the boxes of `in` that `t` may reach, in order, in out[0, result). `out` must have room
// for in.n entries.
size_t FilterList(const BeamTest& t, const ListView& in, const ListOut& out);
// FilterList of `in` for two beams into out[0] and out[1], kept[j] entries each: one pass over
// the list where the vector filter runs and the beams' signs agree (a node's two halves).
void FilterPair(const BeamTest t[2], const ListView& in, const ListOut out[2], size_t kept[2]);

}  // namespace rayclass::classify
