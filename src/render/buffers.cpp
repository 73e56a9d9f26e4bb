#include "rayclass/render/buffers.h"

#include <algorithm>
#include <vector>

#include "rayclass/render/device_scene.h"
#include "rayclass/render/launch.h"

namespace rayclass::render {

namespace {

// A read-only buffer of convert(item) for each of `items` (one zeroed element when there are
// none), written in place through a mapping. On a device that shares host memory (PoCL on the
// CPU) each element is written once: converting into host arrays and creating the buffers from
// them (CL_MEM_COPY_HOST_PTR) wrote every primitive twice, a visible share of a one-frame
// render's time on large meshes.
template <typename Items, typename F>
cl::Buffer ConvertedBuffer(clrt::Context& ctx, const Items& items, F&& convert) {
    using T = decltype(convert(items[0]));
    const size_t n = std::max<size_t>(items.size(), 1);
    cl::Buffer buffer = DeviceBuffer(ctx, n * sizeof(T), CL_MEM_READ_ONLY | CL_MEM_ALLOC_HOST_PTR);
    T* out = static_cast<T*>(clrt::Check("clEnqueueMapBuffer", [&] {
        return ctx.queue().enqueueMapBuffer(buffer, CL_TRUE, CL_MAP_WRITE_INVALIDATE_REGION, 0,
                                            n * sizeof(T));
    }));
    if (items.empty()) out[0] = T{};
    for (size_t i = 0; i < items.size(); ++i) out[i] = convert(items[i]);
    clrt::Check("clEnqueueUnmapMemObject", [&] { ctx.queue().enqueueUnmapMemObject(buffer, out); });
    return buffer;
}

}  // namespace

SceneBuffers::SceneBuffers(clrt::Context& ctx, const scene::Scene& scene,
                           const RcRenderParams& renderParams)
    : triangles(ConvertedBuffer(ctx, scene.triangles, kToDevice)),
      triangleShading(ConvertedBuffer(ctx, scene.triangles, ShadingOf)),
      spheres(ConvertedBuffer(ctx, scene.spheres, kToDevice)),
      quadrics(UploadVector(ctx, AnalyticArray(scene))),
      materials(ConvertedBuffer(ctx, scene.materials, kToDevice)),
      lights(ConvertedBuffer(ctx, scene.lights, kToDevice)),
      params(UploadVector(ctx, std::vector<RcRenderParams>{renderParams})),
      hostParams(renderParams) {}

uint64_t SceneBuffers::GeometryBytes() const {
    uint64_t bytes = 0;
    for (const cl::Buffer* b : {&triangles, &triangleShading, &spheres, &quadrics}) {
        bytes += clrt::Check("clGetMemObjectInfo", [&] { return b->getInfo<CL_MEM_SIZE>(); });
    }
    return bytes;
}

ShadeBuffers MakeShadeBuffers(clrt::Context& ctx, size_t rays, uint32_t nLights) {
    ShadeBuffers shade;
    shade.radiance = DeviceBuffer(ctx, rays * sizeof(rc_float4));
    shade.normals = DeviceBuffer(ctx, rays * sizeof(rc_float4));
    shade.shadow = {DeviceBuffer(ctx, rays * nLights * sizeof(RcRay)),
                    DeviceBuffer(ctx, rays * nLights * sizeof(rc_float4))};
    shade.secondary = {DeviceBuffer(ctx, SecondarySlots(rays) * sizeof(RcRay)),
                       DeviceBuffer(ctx, SecondarySlots(rays) * sizeof(RcRayInfo))};
    shade.spawned = DeviceBuffer(ctx, 2 * rays);
    return shade;
}

}  // namespace rayclass::render
