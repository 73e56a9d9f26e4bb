#include "rayclass/render/grid_query.h"

#include "ray_counters.h"
#include "rayclass/render/launch.h"

namespace rayclass::render {

namespace {

class GridQuery final : public RayQuery {
  public:
    GridQuery(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene,
              const accel::Grid& grid)
        : ctx_(ctx),
          scene_(scene),
          cellStart_(UploadVector(ctx, grid.cellStart)),
          primIndex_(UploadVector(ctx, grid.primIndex)),
          boxLo_{grid.box.lo.x, grid.box.lo.y, grid.box.lo.z, grid.pad * 0.25f},
          boxHi_{grid.box.hi.x, grid.box.hi.y, grid.box.hi.z, 0.0f},
          cellSize_{grid.cellSize.x, grid.cellSize.y, grid.cellSize.z, 0.0f},
          res_{grid.resolution.x, grid.resolution.y, grid.resolution.z, 0u},
          intersect_(program, "rc_intersect_grid"),
          occluded_(program, "rc_occluded_grid") {
        stats_.accel = {{"grid_cells", double(grid.Cells())},
                        {"grid_empty_cells", double(grid.emptyCells)},
                        {"grid_resolution_x", double(grid.resolution.x)},
                        {"grid_resolution_y", double(grid.resolution.y)},
                        {"grid_resolution_z", double(grid.resolution.z)},
                        {"grid_references", double(grid.primIndex.size())},
                        {"grid_bytes", double(grid.Bytes())},
                        {"grid_rays", 0.0},
                        {"grid_cells_visited", 0.0}};
    }

    std::string Name() const override { return "grid"; }
    QueryStats Stats() const override { return stats_; }

    QueryResult Intersect(const cl::Buffer& rays, uint32_t n, const PreparedBatch*,
                          const cl::Buffer& hits, const ShadeBuffers&,
                          KernelTimer& timer) override {
        return {Run(intersect_, rays, n, hits, timer), false};
    }

    uint64_t Occluded(const cl::Buffer& shadowRays, std::span<const RcRay> hostRays,
                      const cl::Buffer& blocked, KernelTimer& timer) override {
        return Run(occluded_, shadowRays, uint32_t(hostRays.size()), blocked, timer);
    }

  private:
    uint64_t Run(cl::Kernel& kernel, const cl::Buffer& rays, uint32_t n, const cl::Buffer& out,
                 KernelTimer& timer) {
        if (n == 0) return 0;
        SetArgs(kernel, rays, n, cellStart_, primIndex_, boxLo_, boxHi_, cellSize_, res_,
                scene_.triangles, scene_.spheres, scene_.quadrics, scene_.params, out,
                counters_.Reserve(ctx_, n));
        Launch(ctx_, kernel, n, timer);
        const CounterSums sums = counters_.Sum(ctx_, n);
        stats_.accel["grid_rays"] += n;
        stats_.accel["grid_cells_visited"] += double(sums.steps);
        return sums.tests;
    }

    clrt::Context& ctx_;
    const SceneBuffers& scene_;
    cl::Buffer cellStart_, primIndex_;
    cl_float4 boxLo_, boxHi_, cellSize_;
    cl_uint4 res_;
    cl::Kernel intersect_, occluded_;
    RayCounters counters_;
    QueryStats stats_;
};

}  // namespace

std::unique_ptr<RayQuery> MakeGridQuery(clrt::Context& ctx, const cl::Program& program,
                                        const SceneBuffers& buffers, const scene::Scene& scene,
                                        const accel::GridParams& params) {
    return std::make_unique<GridQuery>(ctx, program, buffers, accel::BuildGrid(scene, params));
}

}  // namespace rayclass::render
