// The 5D conversion of a generation's rays: each ray to its point in its face's frame (X, Y, Z,
// u, v and the X where it ends), written to its face's structure-of-arrays slab. The AVX-512 path
// maps 16 rays at a time with the float operations of the scalar one (ToRay5, ToRay5Clipped), so
// the points are bit-identical. Private to the classify module.
#pragma once

#include <cstdint>
#include <vector>

#include "rayclass/classify/ray5d.h"
#include "rc_types.h"
#include "support.h"

namespace rayclass::classify {

// The coordinates of each face's rays that ConvertRays has not stored because all its rays had
// the same value there (eye rays' origins, unbounded rays' ends): those are never read, and
// skipping them saves about a third of the conversion's memory traffic. Bit k of `mask` is
// coordinate k; `value` is the first ray's point.
struct HeldCoords {
    bool seen[kFaceCount] = {};
    unsigned mask[kFaceCount] = {};
    float value[kFaceCount][kCoords];
};

// Where ConvertRays writes: one array per coordinate and one of ray ids.
struct FaceSlabs {
    float* coord[kCoords];
    uint32_t* id;
};

// Maps `rays`, ids from firstId on (each taken from its common end where `ends` has one), to their
// points in the frames of `sceneBox`: a ray of face f goes to position next[f]++ of `out`, and
// grows faceBounds[f]. Coordinates held back stay in `held` (see HeldCoords). Rays that miss the
// box go to `missed`. Returns how many rays were taken from an end.
uint64_t ConvertRays(RayView rays, const CommonEnds& ends, const Bounds3f& sceneBox,
                     uint32_t firstId, const FaceSlabs& out, uint32_t* next, Bounds6* faceBounds,
                     HeldCoords& held, std::vector<rc_uint>& missed);

}  // namespace rayclass::classify
