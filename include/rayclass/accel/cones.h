// The host side of Szecsi's hierarchical ray engine (--accel cones): rays sorted so that each
// tile of consecutive rays is coherent, the cone construction (the query's cones are built on the
// device by the same steps, cl/cones.cl; the host's decides whether a batch keeps its order), and
// a bounding sphere per primitive for the kernels' cone-sphere culling.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rayclass/scene/scene.h"
#include "rc_types.h"

namespace rayclass::accel {

// Rays per tile, and tiles per cone of the level above.
constexpr uint32_t kConeTileRays = 64;
constexpr uint32_t kConeGroupTiles = 16;

// Indices of rays[0, n) in the order of a Morton code over their origins (in `box`) and their
// directions together, so that runs of consecutive indices are coherent rays: for eye rays,
// compact screen tiles.
std::vector<uint32_t> CoherentOrder(std::span<const RcRay> rays, const Bounds3f& box);

// Whether the rays' own order already makes coherent tiles (eye rays in scanline order: a tile is
// a run of a row): the cones of every 16th tile in that order average at most 0.05 radians of
// half-angle, and none is unbounded. Such a batch keeps its order, and saves the sort.
bool CoherentAsGiven(std::span<const RcRay> rays);

// The cone enclosing `rays` (consecutive in CoherentOrder's order): the paper's incremental
// construction, ray by ray step (a) (the smallest cone with the same apex holding the new
// direction) then step (b) (the apex slides back along the far generator until the near one
// passes through the new origin, with the sign our notes correct, and backs off along the axis
// where no slide can reach the origin); then every direction is checked against the final axis
// and the half-angle widened by a margin for the kernels' float arithmetic, and every origin
// checked, the apex backing off along the axis where rounding left one outside. A cone of 89
// degrees or more is marked unbounded. Rays without a direction (empty shadow slots) are left
// out. `margin` is an absolute distance the apex backs off further.
RcCone EnclosingCone(std::span<const RcRay> rays, double margin);

// Bounding spheres of every primitive (global ids) as structure of arrays, x, y, z and radius,
// each padded to a multiple of 16 entries; radii grown by `pad`.
struct PrimitiveSpheres {
    std::vector<float> x, y, z, r;
    uint32_t count = 0;
};
PrimitiveSpheres BoundingSpheres(const scene::Scene& scene, float pad);

}  // namespace rayclass::accel
