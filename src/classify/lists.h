// Candidate lists: the primitives' padded boxes in a face's frame, as structure of arrays in
// 16-bit steps, sorted by their near X. Each face presorts the whole scene once (FaceLists); a
// node's list is filtered from its parent's and keeps that order. Private to the classify module.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>

#include "rayclass/classify/params.h"
#include "rayclass/classify/ray5d.h"
#include "rayclass/core/scratch_vector.h"
#include "rayclass/scene/scene.h"

namespace rayclass::classify {

// The fixed-point frame of a face's candidate boxes: coordinate c on axis k (X, Y, Z of the face)
// is kept as (c - base[k]) / step in 16 bits, lower bounds rounded down and upper ones up, so a
// stored box contains the padded box. The step is one for all three axes, so beam slopes hold in
// steps as they do in world units. Lists hold 16 bytes a box instead of 28: the filter, which
// mostly copies, then moves less memory.
struct ListFrame {
    float base[3] = {0.0f, 0.0f, 0.0f};
    float step = 1.0f;  // world units per step: the largest extent / 65534, rounded up
    // An end X at or beyond this keeps every entry of the frame's lists (CountUpTo): the frame's
    // far X, as each box starts within the frame (infinite when there is none).
    float keepsAll = std::numeric_limits<float>::infinity();
};

// Entries of a list that a block summary (ListBlocks) bounds together.
constexpr size_t kListBlock = 16;

// Per block of kListBlock consecutive entries of a list (the last one may be shorter), the box of
// its boxes in steps: the least lower and greatest upper bound on each axis. The beam test only
// grows with the box, so a beam that cannot reach a block's box reaches none of its entries.
// x0 is null where a list has no summary.
struct ListBlocks {
    const uint16_t* x0 = nullptr;
    const uint16_t* x1 = nullptr;
    const uint16_t* y0 = nullptr;
    const uint16_t* y1 = nullptr;
    const uint16_t* z0 = nullptr;
    const uint16_t* z1 = nullptr;
};

// The first n entries of a candidate list (in `frame`'s steps, sorted by x0), and the summary of
// its blocks where it has one (a cut list keeps its blocks).
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
    ListBlocks blocks = {};
};

// Storage of a list.
struct FaceList {
    ScratchVector<uint16_t> x0, x1, y0, y1, z0, z1;
    ScratchVector<uint32_t> prim;
    size_t Size() const { return prim.size(); }
    size_t Bytes() const { return prim.capacity() * 4 + x0.capacity() * 12; }
    void Resize(size_t n);
};

// Where a filter writes its kept boxes: n entries from these pointers on.
struct ListOut {
    uint16_t* x0;
    uint16_t* x1;
    uint16_t* y0;
    uint16_t* y1;
    uint16_t* z0;
    uint16_t* z1;
    uint32_t* prim;
};

inline ListView View(const FaceList& l, size_t n, const ListFrame* frame) {
    return {l.x0.data(), l.x1.data(),   l.y0.data(), l.y1.data(), l.z0.data(),
            l.z1.data(), l.prim.data(), n,           frame};
}

// Entries [at, ...) of `l`.
inline ListOut Out(FaceList& l, size_t at) {
    return {l.x0.data() + at, l.x1.data() + at, l.y0.data() + at,  l.y1.data() + at,
            l.z0.data() + at, l.z1.data() + at, l.prim.data() + at};
}

// The blocks of a list of n entries.
inline size_t BlockCount(size_t n) { return (n + kListBlock - 1) / kListBlock; }

// The blocks' boxes of a list, stored as a list whose entries are the blocks (prim unused).
inline ListBlocks BlocksOf(const ListOut& b) { return {b.x0, b.x1, b.y0, b.y1, b.z0, b.z1}; }
inline ListBlocks BlocksOf(const FaceList& b) {
    return {b.x0.data(), b.x1.data(), b.y0.data(), b.y1.data(), b.z0.data(), b.z1.data()};
}

// Every primitive of the scene, presorted per face: the roots' lists, with their blocks'
// summaries where the filter reads them (FilterSkipsBlocks). Read-only once built, so copies of
// a hierarchy share them.
struct FaceLists {
    std::array<FaceList, kFaceCount> list;
    std::array<FaceList, kFaceCount> blocks;
    ListFrame frame[kFaceCount];

    ListView Whole(int face) const {
        ListView v = View(list[face], list[face].Size(), &frame[face]);
        if (blocks[face].Size() > 0) v.blocks = BlocksOf(blocks[face]);
        return v;
    }
    size_t Bytes() const;
};

// The face lists of `scene`'s primitives, each box padded by params.padding.
std::shared_ptr<const FaceLists> BuildFaceLists(const scene::Scene& scene, const Params& params);

}  // namespace rayclass::classify
