// Ray queries through a uniform grid filled by conservative voxelization (rayclass/accel/grid.h)
// walked by cl/grid.cl's 3D-DDA: the voxelization paper's structure, in the same kernels and
// with the same intersection routines as every other query (--accel grid).
#pragma once

#include <memory>

#include "rayclass/accel/grid.h"
#include "rayclass/render/ray_query.h"

namespace rayclass::render {

// Builds the grid of `scene` (whose primitives `buffers` holds) and uploads it. The query finds
// hits only; the renderer shades them. Its Stats().accel: grid_cells, grid_empty_cells,
// grid_resolution_x/y/z, grid_references, grid_bytes, and over the rays it answered grid_rays
// and grid_cells_visited.
std::unique_ptr<RayQuery> MakeGridQuery(clrt::Context& ctx, const cl::Program& program,
                                        const SceneBuffers& buffers, const scene::Scene& scene,
                                        const accel::GridParams& params = {});

}  // namespace rayclass::render
