// Statistics of the ray classification for one generation of rays: what `rayclass classify-stats`
// and bench/classify/classify_bench print. Also the two standard workloads they measure: the eye rays of
// the anchor camera (scenes/bench/README.md), one generation of mirror rays and one of
// shadow rays.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rayclass/classify/hierarchy.h"
#include "rayclass/geometry/intersect.h"

namespace rayclass::classify {

struct ClassifyStats {
    uint32_t nRays = 0;
    uint32_t nMissed = 0;          // rays that miss the scene box
    uint32_t nLeaves = 0;
    uint32_t nNodes = 0;           // all nodes of the hierarchy after the generation
    uint32_t maxDepth = 0;         // deepest leaf
    double avgCandidates = 0.0;    // leaf list length per classified ray
    uint32_t maxCandidates = 0;    // longest list a ray got
    double testsPerRay = 0.0;      // host query with distance optimisation, per ray of the batch
    uint32_t bruteForceTests = 0;  // per ray: every primitive
    double boxTestsPerRay = 0.0;   // candidate tests while filtering lists
    double rayMovesPerRay = 0.0;   // levels a ray was moved through
    double classifyNsPerRay = 0.0; // Insert + Subdivide, median over the repeats, calling thread only
    double classifyCpuNsPerRay = 0.0;  // the same in the thread's CPU time (excludes preemption)
    double queryNsPerRay = 0.0;    // scalar host query (reference path, not the device's)
    double setupMs = 0.0;          // per-scene preprocessing: presorted face lists
    size_t hierarchyBytes = 0;     // nodes + face lists + peak scratch
    size_t leafBytes = 0;          // the LeafBatch arrays
    size_t peakRssBytes = 0;       // process high-water mark (VmHWM) after the run; 0 if unknown
    bool classifiedFromCamera = false;  // by Hierarchy::ClassifyPinhole (see ComputeStats)
};

// Classifies `rays` `repeats` times in a fresh hierarchy (the median time counts), queries them
// once on the host (any hit with `anyHit`) and fills every field. When `hits` is not empty it
// receives the query's hits.
// With `pinhole`, `rays` are that camera's eye rays and are classified by
// Hierarchy::ClassifyPinhole instead, unless it refuses the camera (classifiedFromCamera says).
ClassifyStats ComputeStats(const scene::Scene& scene, std::span<const Ray> rays,
                           const Params& params, int repeats = 3,
                           std::span<geometry::Hit<float>> hits = {}, bool anyHit = false,
                           const RcCamera* pinhole = nullptr);

// The anchor camera: eye = box centre - 0.25 size_x (1, 0, 0), looking along +x, up +y, right +z,
// vertical field of view 60 degrees, pixel centres, row 0 at the top.
RcCamera AnchorCamera(const scene::Scene& scene, uint32_t width, uint32_t height);
// The rays of pixels [first, first + n) of `camera` by cl/camera.cl's formula in float (ray i is
// pixel first + i), and all of the anchor camera's.
std::vector<Ray> CameraRays(const RcCamera& camera, uint32_t first, uint32_t n);
std::vector<Ray> AnchorEyeRays(const scene::Scene& scene, uint32_t width, uint32_t height);

// One mirror bounce of every ray that hit: origin P + 1e-4 diagonal n (n the geometric normal
// facing the ray), direction d - 2 (d.n) n normalised, tMin 0.
std::vector<Ray> MirrorRays(const scene::Scene& scene, std::span<const Ray> rays,
                            std::span<const geometry::Hit<float>> hits);

// One shadow ray per ray that hit, from the hit point P towards the point light `light`:
// direction normalised, tMin 1e-4 diagonal (the anchors' tnear), tMax |light - P|.
std::vector<Ray> ShadowRays(std::span<const Ray> rays, std::span<const geometry::Hit<float>> hits,
                            const glm::vec3& light, float tMin);

// The anchors' shadow light: box centre + f size_y (0, 1, 0) (sibenik f = 0.1).
glm::vec3 AnchorLight(const scene::Scene& scene, float f = 0.1f);

// The process's peak resident set (VmHWM), in bytes; 0 where /proc is not available.
size_t PeakRssBytes();

}  // namespace rayclass::classify
