// Ray queries through a SAH kd-tree (rayclass/accel/kdtree.h) walked by cl/kdtree.cl: the
// object hierarchy of the Pinocchio tracer, in the same kernels and with the same intersection
// routines as every other query (--accel kdtree).
#pragma once

#include <memory>

#include "rayclass/accel/kdtree.h"
#include "rayclass/render/ray_query.h"

namespace rayclass::render {

// Builds the tree of `scene` (whose primitives `buffers` holds) and uploads it. The query finds
// hits only; the renderer shades them. Its Stats().accel: kdtree_nodes, kdtree_leaves,
// kdtree_empty_leaves, kdtree_references, kdtree_bytes, kdtree_max_depth, and over the rays it
// answered kdtree_rays and kdtree_nodes_visited.
std::unique_ptr<RayQuery> MakeKdTreeQuery(clrt::Context& ctx, const cl::Program& program,
                                          const SceneBuffers& buffers, const scene::Scene& scene,
                                          const accel::KdBuildParams& params = {});

}  // namespace rayclass::render
