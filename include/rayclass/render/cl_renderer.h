// The OpenCL Whitted renderer: eye rays from a kernel, then generation by generation a ray query
// (behind RayQuery, so accelerations swap in locally), a shading kernel that spawns shadow,
// reflection and refraction rays, and a shadow query. Contributions are accumulated per pixel on
// the host in ray order, so a render is reproducible bit for bit.
#pragma once

#include <map>
#include <memory>
#include <span>
#include <string>

#include "rayclass/clrt/context.h"
#include "rayclass/image/image.h"
#include "rayclass/render/device_scene.h"
#include "rayclass/render/options.h"
#include "rayclass/render/stats.h"
#include "rayclass/scene/scene.h"

namespace rayclass::render {

// Sums the device time of every launch per kernel name.
class KernelTimer {
  public:
    void Record(const std::string& kernel, const cl::Event& event);
    const std::map<std::string, double>& Seconds() const { return seconds_; }

  private:
    std::map<std::string, double> seconds_;
};

// Scene data every kernel reads, uploaded once.
struct SceneBuffers {
    cl::Buffer triangles, triangleShading, spheres, quadrics, materials, lights, params;
    RcRenderParams hostParams{};

    SceneBuffers(clrt::Context& ctx, const scene::Scene& scene, const RcRenderParams& renderParams);
};

// A device array of rays as its two parallel arrays (rc_types.h): RcRay, all a query reads, and
// RcRayInfo, which only ray generation and shading touch.
struct RayBuffers {
    cl::Buffer rays, info;
};

// Shadow slots as their two parallel arrays (rc_types.h): RcRay toward the light, all the
// occlusion query reads, and the light's contribution (rc_float4, w = 1 when the slot is live).
struct ShadowBuffers {
    cl::Buffer rays, contribution;
};

// What shading reads and writes per batch (see cl/shade.cl): it reads the batch's RcRayInfo and
// writes radiance and normal per ray, nLights shadow slots per ray, two secondary slots per ray
// and their spawned flags.
struct ShadeBuffers {
    cl::Buffer rayInfo;  // the batch's, set for each batch (null for eye rays: rc_types.h)
    cl::Buffer radiance, normals;
    // Whether the batch's shading normals are wanted (the renderer: for the normal AOV). Without
    // them a kernel gets no normals buffer and writes none, sparing a buffer's worth of memory
    // traffic, unless a later pass of its own reads them.
    bool writeNormals = true;

    // The normals buffer a shading kernel gets: none unless the normals are wanted or a later
    // pass reads them (`passReadsThem`: rc_shade_lights reads what rc_shade_ids saved).
    cl::Buffer NormalsOut(bool passReadsThem = false) const {
        return writeNormals || passReadsThem ? normals : cl::Buffer();
    }
    ShadowBuffers shadow;
    RayBuffers secondary;
    cl::Buffer spawned;
};

// ShadeBuffers for batches of up to `rays` rays and `nLights` lights (rayInfo left unset: it is
// the batch's own).
ShadeBuffers MakeShadeBuffers(clrt::Context& ctx, size_t rays, uint32_t nLights);

struct QueryResult {
    uint64_t tests = 0;   // primitive intersection tests done
    bool shaded = false;  // the query's kernels shaded every ray too (into ShadeBuffers)
};

// The host-side work a query does on a batch before its kernels can run (ray classification).
// Prepare makes it, on a worker thread while the device works on the previous batch.
struct PreparedBatch {
    virtual ~PreparedBatch() = default;
};

// Where a batch of rays came from, when a query can use that instead of reading them back: the
// eye rays that rc_generate_eye_rays wrote for `camera` with float directions (not polar16),
// pixels [firstPixel, firstPixel + n). Null camera: the rays alone say.
struct RaySource {
    const RcCamera* camera = nullptr;
    uint32_t firstPixel = 0;
};

// How the rays of a batch find their nearest hit and their occluders. The rays are on the
// device already.
class RayQuery {
  public:
    virtual ~RayQuery() = default;
    virtual std::string Name() const = 0;
    // Host work on the batch rays[0, n) (RcRay) before its kernels can run, e.g. classifying the
    // rays, which it reads back through `queue` (not the queue the kernels run on, so the read
    // does not wait for them). Called in batch order, from one thread at a time, possibly
    // concurrently with Intersect or Occluded of an earlier batch. nullptr: nothing to prepare.
    // `source` may let the query skip reading the rays.
    virtual std::unique_ptr<PreparedBatch> Prepare(const cl::Buffer& rays, uint32_t n,
                                                   const cl::CommandQueue& queue,
                                                   const RaySource& source) {
        (void)rays, (void)n, (void)queue, (void)source;
        return nullptr;
    }
    // Takes a batch back once its Intersect has run, so the next Prepare reuses its memory
    // (fresh pages cost more than classifying into them).
    virtual void Recycle(std::unique_ptr<PreparedBatch> batch) { (void)batch; }
    // Host time spent so far (classification, building the batch arrays), summed over threads.
    virtual double HostSeconds() const { return 0.0; }
    // Shadow rays answered so far that the classification took from their light.
    virtual uint64_t ShadowRaysFromLight() const { return 0; }
    // Of them, those sorted into cells of their direction from the light
    // (classify::Hierarchy::SubdivideFromEnds).
    virtual uint64_t ShadowRaysInCells() const { return 0; }
    // Eye rays classified so far from their camera (RaySource), not read back.
    virtual uint64_t EyeRaysFromCamera() const { return 0; }
    // Called once all of generation `generation`'s rays are on the device, before its first
    // Prepare (not for generation 0 when another source supplies its hits); rays[0, n) (RcRay)
    // are its first batch and the device is idle. A query that picks its method per generation
    // (auto_query.h) picks it here.
    virtual void BeginGeneration(uint32_t generation, const cl::Buffer& rays, uint32_t n,
                                 KernelTimer& timer) {
        (void)generation, (void)rays, (void)n, (void)timer;
    }
    // Says in `gen` what answered the generation's queries, once it is done.
    virtual void DescribeGeneration(GenerationStats& gen) const {
        gen.query = gen.shadowQuery = Name();
    }
    // Forgets what earlier batches built (the classification's splits) but keeps every
    // allocation: the next batch is answered as if by a new query whose memory is already
    // faulted in (raybench --warm measures the steady state this way).
    virtual void Reset() {}
    // Nearest hit of rays[0, n) (RcRay) into hits (RcHit). Query styles whose kernels shade
    // the hits they find (vertex style) also read shade.rayInfo, write `shade` and say so.
    virtual QueryResult Intersect(const cl::Buffer& rays, uint32_t n, const PreparedBatch* prepared,
                                  const cl::Buffer& hits, const ShadeBuffers& shade,
                                  KernelTimer& timer) = 0;
    // blocked[i] = 1 when shadow ray i (RcRay, tmax = distance to the light; empty slots have
    // no direction) hits anything before its light; returns the primitive tests done.
    virtual uint64_t Occluded(const cl::Buffer& shadowRays, std::span<const RcRay> hostRays,
                              const cl::Buffer& blocked, KernelTimer& timer) = 0;
};

// Every ray against every primitive.
std::unique_ptr<RayQuery> MakeBruteForceQuery(clrt::Context& ctx, const cl::Program& program,
                                              const SceneBuffers& scene);

// The program holding every kernel the renderer uses, with the options they need
// (*fromCache: see clrt::Context::BuildProgram).
cl::Program BuildRenderProgram(const clrt::Context& ctx, const std::string& extraOptions = {},
                               bool* fromCache = nullptr);

// Supplies the nearest hits of generation 0 (the eye rays) in place of the ray query, e.g. the
// OpenGL raster pass. FindHits returns one RcHit per pixel, row-major, row 0 at the top, for the
// rays rc_generate_eye_rays makes from `camera`.
class EyeHitSource {
  public:
    virtual ~EyeHitSource() = default;
    virtual std::string Name() const = 0;
    virtual std::vector<RcHit> FindHits(const scene::Scene& scene, const CameraBasis& camera,
                                        RenderStats& stats) = 0;
};

class ClRenderer {
  public:
    // With options.eyeRays == "raster", `eyeHits` (required then) answers generation 0; the eye
    // rays themselves still come from the kernel.
    ClRenderer(clrt::Context& ctx, const scene::Scene& scene, const RenderOptions& options,
               EyeHitSource* eyeHits = nullptr);
    image::Image Render(RenderStats& stats);

  private:
    clrt::Context& ctx_;
    const scene::Scene& scene_;
    RenderOptions options_;
    EyeHitSource* eyeHits_;
};

}  // namespace rayclass::render
