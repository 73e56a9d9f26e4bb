// The contract between the renderer and its accelerations: how the rays of a batch, already on
// the device, find their nearest hits and their occluders. A query is a strategy behind RayQuery
// (brute_query.h, bvh_query.h, classified_query.h, auto_query.h), so one swaps in locally.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>

#include "rayclass/clrt/context.h"
#include "rayclass/render/buffers.h"
#include "rayclass/render/launch.h"
#include "rayclass/render/stats.h"
#include "rc_types.h"

namespace rayclass::render {

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

// What a query counts besides its tests, summed over the render so far (zero where it does not
// apply: only the classification has host work and rays classified from their ends).
struct QueryStats {
    double hostSeconds = 0;  // host work (classification, the batch arrays), summed over threads
    uint64_t shadowRaysFromLight = 0;  // shadow rays classified from their light
    // Of them, those sorted into cells of their direction from the light
    // (src/classify/light_cells.h).
    uint64_t shadowRaysInCells = 0;
    uint64_t eyeRaysFromCamera = 0;  // eye rays classified from their camera (RaySource), unread
    // The query's own figures (--stats "accel_stats", docs/stats.md): its structure's size and
    // what its kernels counted, e.g. "kdtree_nodes_visited".
    std::map<std::string, double> accel;
};

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
    virtual QueryStats Stats() const { return {}; }
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

}  // namespace rayclass::render
