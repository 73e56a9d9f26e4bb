// Moving a node's rays between the ping-pong buffers of the hierarchy: two-way partitions at one
// split value, and the plans' buckets over several levels of splits at once. The rays are
// structure-of-arrays (one array per coordinate and one of ids); coordinates that do not vary
// among a face's rays are not moved. Private to the classify module.
#pragma once

#include <cstdint>

#include "rayclass/core/scratch_vector.h"
#include "support.h"

namespace rayclass::classify {

// Where a partition reads and writes the rays of a node: one array per dimension, and the ids.
struct PartitionIo {
    const float* src[kCoords];
    float* dst[kCoords];
    const uint32_t* srcId;
    uint32_t* dstId;
    const float* key;
};

// Reads buffer `from` (coordinates and ids) and writes `to`; the key is the caller's.
PartitionIo Between(const ScratchVector<float>* from, ScratchVector<float>* to,
                    const ScratchVector<uint32_t>& fromId, ScratchVector<uint32_t>& toId);

// The bounds of x[0, n).
void MinMax(const float* x, size_t n, float& lo, float& hi);

// Moves the rays with key < value to the front of [begin, end) of the destination (in order) and
// the others to the back (reversed), for the coordinates whose bits are set in `active` only, and
// gathers both sides' bounds of those coordinates on the way (the others are left to the caller).
// Returns the first right-side position.
uint32_t PartitionRays(int active, const PartitionIo& io, float value, uint32_t begin, uint32_t end,
                       Bounds6& leftBox, Bounds6& rightBox);

// Whether keys[begin, end) are already split at `value`: all keys below it first, or all keys
// below it last. Then *first is the length of the first run and *firstLeft whether it holds the
// keys below. Gives up at the second change of side, so an unordered range costs a block or
// two. Rays that arrive in an order matching the splits (eye rays in pixel order, whose rows
// are intervals of one slope) are then split without being moved.
bool AlreadySplit(const float* key, float value, uint32_t begin, uint32_t end, uint32_t* first,
                  bool* firstLeft);

// What BucketRays reads: the plan's levels, the dimension each splits and the splits' values in
// heap order (plan node h's children are 2h + 1 and 2h + 2; the cells are the last level's).
struct CellRule {
    int levels;
    const int* dim;
    const float* value;
};

// Puts the rays [begin, end) of `io` into the cells of `rule`, each cell's rays in ray order,
// cells one after another from `begin` (cellBegin[c] is where cell c starts, cellBegin[2^levels]
// is end), and gathers each cell's bounds of the active coordinates on the way. A ray goes right
// at a level when its key is not below the split value, as PartitionRays decides. `pieces`
// threads share the work, each counting and then moving a run of the rays; the result does not
// depend on their number.
void BucketRays(const PartitionIo& io, const bool* active, const CellRule& rule, uint32_t begin,
                uint32_t end, uint32_t* cellBegin, Bounds6* cell, int pieces);

// Moves the rays [begin, end) of io.src into io.dst by the child of an earlier split whose
// interval contains them: box0's, else box1's, else the remainder's (groups 0, 1, 2, each in ray
// order, one after the other); count[g] gets each group's size. Coordinates whose `active` entry
// is false are not moved: all rays have the value `constant` there. `dest` (room for end
// entries) is scratch.
void GroupRays(const PartitionIo& io, const bool* active, const float* constant, const Box5& box0,
               const Box5& box1, uint32_t begin, uint32_t end, uint32_t* dest, uint32_t count[3]);

}  // namespace rayclass::classify
