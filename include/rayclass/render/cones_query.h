// Ray queries by Szecsi's hierarchical ray engine (rayclass/accel/cones.h, cl/cones.cl): each
// batch's rays sorted into coherent tiles on the host, then on the device a cone around each tile
// and each group of tiles, primitives culled against the cones, and every ray tested against its
// tile's survivors (--accel cones).
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "rayclass/render/ray_query.h"

namespace rayclass::render {

// The query finds hits only; the renderer shades them. Its Stats().accel: cones_rays,
// cones_tiles, cones_groups, cones_unbounded (tiles and groups whose cone culls nothing),
// cones_sphere_tests (cone-sphere tests of both levels), cones_candidates (the tiles' survivors
// summed over tiles), cones_culled (the share of tile-primitive pairs culled) and
// cones_host_seconds (sorting rays into tiles).
std::unique_ptr<RayQuery> MakeConesQuery(clrt::Context& ctx, const cl::Program& program,
                                         const SceneBuffers& buffers, const scene::Scene& scene);

// The cones cl/cones.cl builds on the device for rays already in tile order: one a tile of
// accel::kConeTileRays consecutive rays, one a group of accel::kConeGroupTiles tiles, every apex
// backed off by `margin` further (the query builds them in its own buffers; for tests).
struct ConeLevels {
    std::vector<RcCone> tiles, groups;
};
ConeLevels BuildCones(clrt::Context& ctx, const cl::Program& program, std::span<const RcRay> sorted,
                      double margin);

}  // namespace rayclass::render
