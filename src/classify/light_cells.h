// The shadow-ray strategy: any-hit rays that all end at common points (point lights) classified
// from there by cells of their direction, without moving them level by level.
//
// From its point, a light's rays share their origin: only their direction and their end vary.
// One counting sort puts the rays in order of a key: the point, the face of the direction from
// it and the (u, v) cell of a grid of 2^bits x 2^bits on that face, the cell's bits interleaved
// (u's first), so that every halving of a cell range, u and v in turn, leaves two ranges of keys
// and of rays. The hierarchy is the binary tree of those halvings, split by the cost function; a
// node's bounds come from a pyramid of the cells' (u, v) ranges and largest ends, so no node
// reads a ray. A node's (u, v) bounds are those of its non-empty cells, looser than its rays' by
// up to a cell on each side: the grid is fine enough that leaves span several cells. A single
// cell with a long list that the cost function would still split (a thin cone through dense
// geometry) is split ray by ray below the grid, its rays read again. Each leaf gets a node of its
// own that no other links to. Private to the classify module.
#pragma once

#include <cstdint>
#include <vector>

#include "core.h"
#include "light_cones.h"

namespace rayclass::classify {

// The bounds of the rays of a range of direction cells: their (u, v) cells and their largest end
// X.
struct CellBox {
    uint8_t uLo, uHi, vLo, vHi;  // in cells; uLo > uHi when no cell holds a ray
    float end;
};

// Consecutive rays of a piece (by id) that share a key (kNoNode: rays that miss). A piece's runs
// cover its rays in order, each up to where the next starts, so that pass 2 reads a run, not
// every ray's key.
struct CellRun {
    uint32_t key, first;
};

// Where pass 1 writes a piece's runs (room for one a ray and one more, `nRuns` of them written),
// and its cells' counts and largest ends.
struct KeyOut {
    CellRun* runs;
    uint32_t* count;
    float* end;
    uint32_t nRuns = 0;
};

class LightCellSubdivision {
  public:
    explicit LightCellSubdivision(Core& core) : core_(core), cones_(core) {}

    // Classifies `gen` into `out` when it is one array of any-hit rays that end at common points
    // (or miss); false, with `out` untouched, otherwise.
    bool Classify(const Generation& gen, LeafBatch& out);

  private:
    // A node: the cells whose keys start with `prefix`, `depth` bits long, within root `root`
    // (point * kFaceCount + face).
    struct CellAt {
        uint32_t root = kNoNode;
        uint32_t prefix = 0;
        int depth = 0;
    };
    // A ray of a cell that is split further than the grid: its slopes, its end and its id.
    struct CellRay {
        float u, v, end;
        uint32_t id;
    };
    // The direction cells of the last generation: the grid, and per root a pyramid of the
    // (u, v) ranges of the non-empty cells under each node of its quadtree, level after level
    // from the root (1, 4, 16, ... entries; level q's index is a key's top 2q bits), with the
    // largest end of their rays.
    struct CellGrid {
        int bits = 0;
        uint32_t roots = 0;
        RayView rays;                                    // the generation's
        CommonEnds ends;                                 // and their points
        float origin[CommonEnds::kMax * kFaceCount][3];  // each root's point in its face's frame
        std::vector<ScratchVector<CellRun>> runs;        // per piece: its runs, then an end
        std::vector<uint32_t> nRuns;                     // per piece
        std::vector<ScratchVector<uint32_t>> count;      // per piece and cell, then positions
        std::vector<ScratchVector<float>> end;           // per piece and cell: the largest end
        // Per root, each cell's first position in the root, then the root's size.
        ScratchVector<uint32_t> begin;
        std::vector<uint32_t> rootBegin;  // per root, its first position; then the total
        ScratchVector<CellBox> box;       // the roots' pyramids, one after another
    };
    // Pass 1's pieces: runs of whole blocks of 16 rays, a thread's each.
    struct Pieces {
        int threads;
        size_t step, count;
    };

    // Pass 1: per piece its runs of keys, and each cell's count and largest end; the rays that
    // miss to `missed`, the number taken from their end to `fromEnd`. False when a ray neither
    // ends at a point nor misses.
    bool CountCells(const Pieces& pieces, std::vector<rc_uint>& missed, uint64_t& fromEnd);
    // The runs of keys of `rays` (kNoNode for a ray that misses) to out.runs, and each
    // cell's count and largest end added to out.count and out.end. False as CountCells.
    bool CellKeys(RayView rays, const CommonEnds& ends, uint32_t firstId, KeyOut& out,
                  std::vector<rc_uint>& missed, uint64_t& fromEnd) const;
    // Each cell's first position and each root's pyramid; the counts become each piece's next
    // position. Returns the rays that got a cell.
    uint32_t PlaceCells(const Pieces& pieces);
    // Pass 2: the rays' ids in key order, into rayOut_.
    void SortRays(const Pieces& pieces);
    // The hierarchy over the sorted rays: a task per root with rays.
    void BuildRoots(uint32_t nLeafRays, LeafBatch& out);
    void ProcessCells(Worker& w, CellAt at, const ListView& list, bool reuseList);
    void SpawnCells(const CellAt& at, const ListView& list, bool reuseList);
    Bounds6 CellBounds(const CellAt& at) const;
    // What node `at` filters its list from: `list`, its parent's, or its cone's list when that
    // is shorter up to the node's end.
    ListView Source(Worker& w, const CellAt& at, const Bounds6& tight, const ListView& list);
    // A single cell whose rays the cost function splits further: its rays, read again, are
    // split ray by ray (midpoints of their tight (u, v) bounds) below the grid.
    void RefineCell(Worker& w, uint32_t root, uint32_t begin, uint32_t n, int depth,
                    const ListView& list);
    // Rays [0, n) of `rays`, whose ids go to the output from `slot` on.
    void ProcessCellRays(Worker& w, uint32_t root, CellRay* rays, uint32_t n, uint32_t slot,
                         int depth, const ListView& list, bool reuseList);
    size_t ScratchBytes() const;

    Core& core_;
    CellGrid cells_;
    LightCones cones_;
    rc_uint* rayOut_ = nullptr;  // the output's rayIndex, during Classify
    std::vector<std::vector<CellRay>>
        refine_;  // per worker: the rays of the cell RefineCell splits
};

}  // namespace rayclass::classify
