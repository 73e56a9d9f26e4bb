#include "rayclass/classify/query.h"

#include <cmath>

namespace rayclass::classify {

uint64_t QueryLeafHost(const scene::Scene& scene, const LeafBatch& batch, const RcLeaf& leaf,
                       std::span<const Ray> rays, std::span<geometry::Hit<float>> hits,
                       bool anyHit) {
    const int face = int(leaf.face);
    const int axis = FaceAxis(face);
    const RcCandidate* cand = batch.candidates.data() + leaf.candBegin;
    uint64_t tests = 0;
    for (uint32_t j = 0; j < leaf.rayCount; ++j) {
        const uint32_t id = batch.rayIndex[leaf.rayBegin + j];
        const geometry::Ray<float> ray = ToGeometryRay(rays[id]);
        const float originX = FaceX(face, ray.o);
        // dX/dt along the main axis. An any-hit segment may run either way along the leaf's X
        // (CommonEnds): boxes that start beyond its largest X cannot block it.
        const float dX = FaceSign(face) * ray.d[axis];
        const float speed = std::abs(dX);
        const float endX = originX + (dX > 0.0f ? ray.tMax : ray.tMin) * dX;
        geometry::Hit<float> best;
        best.t = ray.tMax;
        for (uint32_t c = 0; c < leaf.candCount; ++c) {
            if (anyHit && cand[c].nearX > endX) break;
            // Strictly nearer only: a box starting exactly at the hit may hold an equal-t hit
            // with a lower id.
            if (best.Valid() && originX + best.t * speed < cand[c].nearX) break;
            geometry::IntersectPrimitive(scene, cand[c].prim, ray, best);
            ++tests;
            if (anyHit && best.Valid()) break;
        }
        if (!best.Valid()) best.t = std::numeric_limits<float>::infinity();
        hits[id] = best;
    }
    return tests;
}

uint64_t QueryHost(const scene::Scene& scene, const LeafBatch& batch, std::span<const Ray> rays,
                   std::span<geometry::Hit<float>> hits, bool anyHit) {
    uint64_t tests = 0;
    for (const RcLeaf& leaf : batch.leaves) {
        tests += QueryLeafHost(scene, batch, leaf, rays, hits, anyHit);
    }
    for (uint32_t id : batch.missed) hits[id] = geometry::Hit<float>{};
    return tests;
}

}  // namespace rayclass::classify
