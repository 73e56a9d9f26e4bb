#include "rayclass/render/grid_query.h"

#include "walk_query.h"

namespace rayclass::render {

namespace {

class GridQuery final : public WalkQuery {
  public:
    GridQuery(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene,
              const accel::Grid& grid)
        : WalkQuery(ctx, program, scene, "grid", "cells_visited",
                    {{"grid_cells", double(grid.Cells())},
                     {"grid_empty_cells", double(grid.emptyCells)},
                     {"grid_resolution_x", double(grid.resolution.x)},
                     {"grid_resolution_y", double(grid.resolution.y)},
                     {"grid_resolution_z", double(grid.resolution.z)},
                     {"grid_references", double(grid.primIndex.size())},
                     {"grid_bytes", double(grid.Bytes())}},
                    kPacketRays),
          cellStart_(UploadVector(ctx, grid.cellStart)),
          primIndex_(UploadVector(ctx, grid.primIndex)),
          macroOccupied_(UploadVector(ctx, grid.macroOccupied)),
          boxLo_{{grid.box.lo.x, grid.box.lo.y, grid.box.lo.z, grid.pad * 0.25f}},
          boxHi_{{grid.box.hi.x, grid.box.hi.y, grid.box.hi.z, 0.0f}},
          cellSize_{{grid.cellSize.x, grid.cellSize.y, grid.cellSize.z, 0.0f}},
          res_{{grid.resolution.x, grid.resolution.y, grid.resolution.z, grid.macroSize}} {}

  private:
    void Bind(cl::Kernel& kernel, const cl::Buffer& rays, uint32_t n, const cl::Buffer& out,
              const cl::Buffer& counters) override {
        SetArgs(kernel, rays, n, cellStart_, primIndex_, macroOccupied_, boxLo_, boxHi_, cellSize_,
                res_, scene_.triangles, scene_.spheres, scene_.quadrics, scene_.params, out,
                counters);
    }

    cl::Buffer cellStart_, primIndex_, macroOccupied_;
    cl_float4 boxLo_, boxHi_, cellSize_;
    cl_uint4 res_;
};

}  // namespace

std::unique_ptr<RayQuery> MakeGridQuery(clrt::Context& ctx, const cl::Program& program,
                                        const SceneBuffers& buffers, const scene::Scene& scene,
                                        const accel::GridParams& params) {
    return std::make_unique<GridQuery>(ctx, program, buffers, accel::BuildGrid(scene, params));
}

}  // namespace rayclass::render
