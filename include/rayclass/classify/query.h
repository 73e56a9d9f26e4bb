// The host-side query over classified rays: the scalar reference path for tests and the CPU
// renderer. Each ray of a leaf tests the leaf's candidates in their near-X order with the float
// routines of geometry/intersect.h (lower id wins ties) and stops at the first candidate whose
// box starts beyond its current hit along the face's main axis (distance optimisation, thesis
// Fig. 17). It returns exactly the hit that brute force over all primitives returns.
#pragma once

#include <cstdint>
#include <span>

#include "rayclass/classify/hierarchy.h"
#include "rayclass/geometry/intersect.h"

namespace rayclass::classify {

inline geometry::Ray<float> ToGeometryRay(const Ray& r) {
    return {r.origin, r.direction, r.tMin, r.tMax};
}

// Queries the rays of leaf `leaf` of `batch`; writes hits[rayIndex] and returns the number of
// primitive tests made. With `anyHit` (shadow rays) a ray stops at its first hit in
// (tMin, tMax), which is then some hit rather than the nearest.
uint64_t QueryLeafHost(const scene::Scene& scene, const LeafBatch& batch, const RcLeaf& leaf,
                       std::span<const Ray> rays, std::span<geometry::Hit<float>> hits,
                       bool anyHit = false);

// Every ray of the batch: leaves, plus "no hit" for the missed rays. `hits` has batch.nRays
// entries. Returns the number of primitive tests made.
uint64_t QueryHost(const scene::Scene& scene, const LeafBatch& batch, std::span<const Ray> rays,
                   std::span<geometry::Hit<float>> hits, bool anyHit = false);

}  // namespace rayclass::classify
