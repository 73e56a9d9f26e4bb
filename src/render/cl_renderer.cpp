#include "rayclass/render/cl_renderer.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <future>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "ray_order.h"
#include "ray_pages.h"
#include "rayclass/clrt/mapped.h"
#include "rayclass/core/two_halves.h"
#include "rayclass/render/launch.h"
#include "rayclass/render/newton_stats.h"
#include "rayclass/render/query_factory.h"

namespace rayclass::render {

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

RcRenderParams MakeRenderParams(const scene::Scene& scene, const RenderOptions& options) {
    RcRenderParams params{};
    params.nTriangles = uint32_t(scene.triangles.size());
    params.nSpheres = uint32_t(scene.spheres.size());
    params.nQuadrics = AnalyticRecords(scene);
    params.nLights = uint32_t(scene.lights.size());
    params.maxDepth = options.maxDepth;
    params.minWeight = options.minWeight;
    params.ambient = {scene.ambient.x, scene.ambient.y, scene.ambient.z, 0.0f};
    params.background = {scene.background.x, scene.background.y, scene.background.z, 0.0f};
    return params;
}

// The frame's program: `given`'s (built before or beside the render: its build time is kept
// apart, the render's wait for it is `program_build`), else the shared one built here, whose
// build the render waits for.
cl::Program FrameProgramOf(clrt::Context& ctx, const RenderOptions& options,
                           const ProgramSource& given, RenderStats& stats) {
    const auto t0 = Clock::now();
    const FrameProgram program = given ? given() : BuildSharedFrameProgram(ctx, options);
    stats.programFromCache = program.fromCache;
    stats.timeS["program_build"] = given ? SecondsSince(t0) : program.seconds;
    if (given) stats.timeS["program_build_thread"] = program.seconds;
    return program.program;
}

// Kernel times and the ray-query time they and the query's host work add up to.
void AddKernelTimes(const KernelTimer& timer, const QueryStats& query, RenderStats& stats) {
    stats.queryTimeS = query.hostSeconds;
    for (const auto& [name, seconds] : timer.Seconds()) {
        stats.timeS["kernel_" + name] = seconds;
        if (name.starts_with("rc_query") || name.starts_with("rc_occluded") ||
            name.starts_with("rc_intersect") || name == "rc_gather_blocks") {
            stats.queryTimeS += seconds;
        }
    }
}

// What neither the kernels' profiling nor the host timers cover of the render: copies between
// host and device, buffer allocation, launch overhead and waiting.
void AddOtherTime(const KernelTimer& timer, double hostSeconds, RenderStats& stats) {
    double accounted = hostSeconds;
    for (const auto& [key, seconds] : stats.timeS) {
        if (key == "program_build" || key == "classify_setup" || key == "bvh_build" ||
            key.starts_with("eye_hits_")) {
            accounted += seconds;
        }
    }
    for (const auto& [name, seconds] : timer.Seconds()) accounted += seconds;
    stats.timeS["transfer_and_other"] = std::max(0.0, stats.timeS["render"] - accounted);
}

// The device buffers a batch works in, allocated once for the largest batch.
struct BatchBuffers {
    BatchBuffers(clrt::Context& ctx, size_t rays, uint32_t nLights)
        : hits(DeviceBuffer(ctx, rays * sizeof(RcHit))),
          shade(MakeShadeBuffers(ctx, rays, nLights)),
          blocked(DeviceBuffer(ctx, rays * nLights)),
          liveSlots(DeviceBuffer(ctx, 2 * rays * sizeof(uint32_t))) {}

    cl::Buffer hits;       // the nearest hits (RcHit)
    ShadeBuffers shade;    // what shading reads and writes
    cl::Buffer blocked;    // the shadow query's answers, a byte a shadow slot
    cl::Buffer liveSlots;  // the secondary slots compaction copies, in slot order
};

// One batch of the generation in flight: page `page`, the generation's rays [first, first + n).
struct Batch {
    uint32_t generation;
    size_t page, first;
    uint32_t n;
};

// The batch's shadow slots, read in place: the rays by the shadow query (its classification
// reads them on the host), the contributions by the accumulation.
struct ShadowSlots {
    ShadowSlots(const cl::CommandQueue& q, const ShadowBuffers& shadow, size_t n)
        : rays(q, shadow.rays, n), contribution(q, shadow.contribution, n) {}
    void Unmap() {
        rays.Unmap();
        contribution.Unmap();
    }
    clrt::MappedRead<RcRay> rays;
    clrt::MappedRead<rc_float4> contribution;
};

// The secondary rays the batch's shading spawned and their flags, read in place: which rays
// live on, and their order, follow from these alone, before the shadow query answers.
struct SpawnedRays {
    SpawnedRays(const cl::CommandQueue& q, const ShadeBuffers& shade, size_t n)
        : flags(q, shade.spawned, 2 * n), rays(q, shade.secondary.rays, SecondarySlots(n)) {}
    // Before compaction reads the rays and the next batch's shading writes them.
    void Unmap() {
        flags.Unmap();
        rays.Unmap();
    }
    clrt::MappedRead<uint8_t> flags;
    clrt::MappedRead<RcRay> rays;
};

// The batch's other outputs, read in place once the shadow query has answered: copies into host
// arrays would fault in their pages again in every one-frame render. Hits and normals only for
// the first-hit layers.
struct BatchOutputs {
    BatchOutputs(const cl::CommandQueue& q, const BatchBuffers& b, uint32_t n, uint32_t nLights,
                 bool aovs)
        : radiance(q, b.shade.radiance, n),
          blocked(q, b.blocked, size_t(n) * nLights),
          hits(q, b.hits, aovs ? n : 0),
          normals(q, b.shade.normals, aovs ? n : 0) {}
    // Before the next batch's shading writes the buffers.
    void Unmap() {
        radiance.Unmap();
        blocked.Unmap();
        hits.Unmap();
        normals.Unmap();
    }
    clrt::MappedRead<rc_float4> radiance;
    clrt::MappedRead<uint8_t> blocked;
    clrt::MappedRead<RcHit> hits;
    clrt::MappedRead<rc_float4> normals;
};

// How many rays ahead the accumulation fetches its pixels.
constexpr uint32_t kPixelsAhead = 16;

// Batches below this many rays are accumulated on one thread: a second one's start costs more
// than it saves.
constexpr size_t kParallelAccumulate = 16384;

// What a generation counts as its batches go by.
struct GenerationTally {
    GenerationStats stats;
    uint64_t reflection = 0, refraction = 0;
    Clock::time_point start;
    double hostBefore = 0;     // the query's host seconds when the generation began
    uint64_t testsBefore = 0;  // the render's intersection tests when it began
};

// Prepares a generation's batches one ahead on a worker thread: the worker reads batch k + 1
// back and classifies it while the device queries and shades batch k.
class Preparer {
  public:
    using Prepare = std::function<std::unique_ptr<PreparedBatch>(size_t page)>;
    Preparer(Prepare prepare, size_t nPages)
        : prepare_(std::move(prepare)),
          nPages_(nPages),
          next_(std::async(std::launch::async, prepare_, 0)) {}

    // Page `page`'s batch, once the worker has prepared it; the worker goes on to the next.
    std::unique_ptr<PreparedBatch> Next(size_t page) {
        std::unique_ptr<PreparedBatch> prepared = next_.get();
        if (page + 1 < nPages_) next_ = std::async(std::launch::async, prepare_, page + 1);
        return prepared;
    }

  private:
    Prepare prepare_;
    size_t nPages_;
    std::future<std::unique_ptr<PreparedBatch>> next_;
};

// Generation 0's pages of `nRays` eye rays, their rays faulted in ahead of rc_generate_eye_rays's
// first writes: where the program is still being built, the render need not wait for this.
RayPages EyePages(PagePool& pool, size_t nRays) {
    RayPages eye;
    for (size_t first = 0; first < nRays; first += pool.PageRays()) {
        eye.pages.push_back(pool.Take());
        const size_t n = std::min(pool.PageRays(), nRays - first);
        PopulateDeviceBuffer(eye.pages.back().rays, n * sizeof(RcRay));
    }
    return eye;
}

std::unique_ptr<RayQuery> WrapQuery(std::unique_ptr<RayQuery> query, const QueryWrapper& wrap) {
    return wrap ? wrap(std::move(query)) : std::move(query);
}

// One Render call: its device state, the generation in flight, and the stages that trace it.
class Frame {
  public:
    Frame(clrt::Context& ctx, const scene::Scene& scene, const RenderOptions& options,
          const ProgramSource& program, EyeHitSource* eyeHitSource, const QueryWrapper& wrapQuery,
          RenderStats& stats);

    // Every generation, from the eye rays until no ray is spawned.
    void Trace() {
        for (uint32_t generation = 0;; ++generation) {
            const size_t nRays = generation == 0 ? nEye_ : rays_.pixels.size();
            if (nRays == 0) break;
            GenerationTally tally = BeginGeneration(generation, nRays);
            const size_t nPages = (nRays + batch_ - 1) / batch_;
            Preparer preparer(
                [this, generation, nRays](size_t page) { return Prepare(generation, nRays, page); },
                nPages);
            for (size_t page = 0; page < nPages; ++page) {
                const size_t first = page * batch_;
                const Batch b{generation, page, first, uint32_t(std::min(batch_, nRays - first))};
                TraceBatch(b, preparer.Next(page), tally);
                ReportProgress(b, nRays);
            }
            EndGeneration(generation, tally);
        }
        if (printedProgress_) std::fprintf(stderr, "\n");
    }

    // The image, once the stats hold every time and count of the render begun at `tStart`.
    image::Image Finish(Clock::time_point tStart);

  private:
    // Generation 0's hits come from the eye-hit source, not the query.
    bool HitsFromSource(uint32_t generation) const { return generation == 0 && eyeHitSource_; }

    GenerationTally BeginGeneration(uint32_t generation, size_t nRays);
    void GenerateEyeRays(size_t nRays);
    std::unique_ptr<PreparedBatch> Prepare(uint32_t generation, size_t nRays, size_t page);
    void TraceBatch(const Batch& b, std::unique_ptr<PreparedBatch> prepared,
                    GenerationTally& tally);
    QueryResult Intersect(const Batch& b, std::unique_ptr<PreparedBatch> prepared);
    void Shade(const Batch& b);
    void Occlude(const ShadowSlots& shadow);
    uint32_t PixelOf(const Batch& b, size_t i) const {
        return b.generation == 0 ? uint32_t(b.first + i) : rays_.pixels[b.first + i];
    }
    void ListLive(const Batch& b, const SpawnedRays& spawned, GenerationTally& tally);
    void Accumulate(const Batch& b, const ShadowSlots& shadow, const BatchOutputs& out,
                    GenerationTally& tally);
    uint64_t AccumulateRange(const Batch& b, const ShadowSlots& shadow, const BatchOutputs& out,
                             size_t begin, size_t end);
    void Compact(const Batch& b);
    void ReportProgress(const Batch& b, size_t nRays);
    void EndGeneration(uint32_t generation, GenerationTally& tally);

    clrt::Context& ctx_;
    const RenderOptions& options_;
    EyeHitSource* eyeHitSource_;
    RenderStats& stats_;
    const CameraBasis basis_;
    image::Image img_;
    // Started before the program build and the scene upload, which it overlaps.
    const std::shared_ptr<BvhBuild> bvhBuild_;
    const RcRenderParams params_;
    // What needs no program comes before it: where the program is still being built (on the
    // thread that started the device), this set-up overlaps the build.
    const SceneBuffers sceneBuffers_;
    const RcCamera cam_;
    const cl::Buffer camBuffer_;
    // Later generations are split into batches of the same size, so no buffer need be larger
    // than the image.
    const size_t batch_;
    BatchBuffers buffers_;
    PagePool pool_;
    RayPages rays_, next_;        // the generation in flight, and the one its batches spawn
    std::vector<uint32_t> live_;  // the batch's live secondary slots
    RayOrder order_;              // the order Compact gives them
    // Some ray has spawned both a reflection and a refraction: a pixel may then have several
    // rays in a generation, whose contributions must reach it in the order they always did.
    bool branched_ = false;
    // No ray spawned both before the generation in flight began: its rays' pixels all differ.
    bool pixelsDiffer_ = true;
    // Prepare's queue: its reads do not wait for the kernels on ctx_.queue().
    cl::CommandQueue readQueue_;
    const cl::Program program_;
    const std::unique_ptr<RayQuery> query_;
    cl::Kernel eyeKernel_, shadeKernel_, compactKernel_;
    KernelTimer timer_;
    double hostSeconds_ = 0;  // the accumulation's
    double listSeconds_ = 0;  // the live slots' listing and ordering (on a worker)
    const size_t nEye_;
    std::vector<RcHit> eyeHits_;           // generation 0's, when the eye-hit source finds them
    std::optional<NewtonSampler> newton_;  // options.newtonStats on a scene with patches
    Clock::time_point lastProgress_;
    bool printedProgress_ = false;
};

Frame::Frame(clrt::Context& ctx, const scene::Scene& scene, const RenderOptions& options,
             const ProgramSource& program, EyeHitSource* eyeHitSource,
             const QueryWrapper& wrapQuery, RenderStats& stats)
    : ctx_(ctx),
      options_(options),
      eyeHitSource_(eyeHitSource),
      stats_(stats),
      basis_(scene.camera, options.window),
      img_(NewImage(basis_, options.aovs)),
      bvhBuild_(StartBvhBuild(scene, options)),
      params_(MakeRenderParams(scene, options)),
      sceneBuffers_(ctx, scene, params_),
      cam_(basis_.ToDevice()),
      camBuffer_(UploadVector(ctx, std::vector<RcCamera>{cam_})),
      batch_(BatchRays(options.batchRays, basis_.window.PixelCount(), params_.nLights,
                       ctx.info().maxAllocBytes)),
      buffers_(ctx, batch_, params_.nLights),
      pool_(ctx, batch_),
      rays_(EyePages(pool_, basis_.window.PixelCount())),
      order_(scene.Bounds()),
      readQueue_(clrt::Check("clCreateCommandQueue",
                             [&] { return cl::CommandQueue(ctx.context(), ctx.device()); })),
      program_(FrameProgramOf(ctx, options, program, stats)),
      query_(WrapQuery(MakeQuery(ctx, program_, sceneBuffers_, scene, options, stats, bvhBuild_),
                       wrapQuery)),
      eyeKernel_(program_, "rc_generate_eye_rays"),
      shadeKernel_(program_, "rc_shade16_ids"),
      compactKernel_(program_, "rc_compact_rays"),
      nEye_(basis_.window.PixelCount()) {
    stats.width = basis_.width;
    stats.height = basis_.height;
    stats.device = ctx.info().name;
    stats.nPrimitives = scene.PrimitiveCount();
    stats.sceneBytes = sceneBuffers_.GeometryBytes();
    stats.accel = query_->Name();
    stats.eyeRays = eyeHitSource ? eyeHitSource->Name() : "kernel";
    if (options.newtonStats && !scene.patchBoxes.empty()) {
        newton_.emplace(ctx, program_, sceneBuffers_, params_.nQuadrics, scene.patchBoxes.size());
    }
    if (eyeHitSource) {
        const auto t0 = Clock::now();
        eyeHits_ = eyeHitSource->FindHits(scene, basis_, stats);
        stats.timeS["eye_hits_" + eyeHitSource->Name()] = SecondsSince(t0);
    }
    lastProgress_ = Clock::now();
}

// Readies generation `generation` of `nRays` rays: the last one's pages go back to the pool,
// the eye rays are generated, and once all its rays are on the device the query begins it.
GenerationTally Frame::BeginGeneration(uint32_t generation, size_t nRays) {
    pool_.Give(next_.pages);
    next_.pixels.clear();
    pixelsDiffer_ = !branched_;
    if (generation == 0) GenerateEyeRays(nRays);
    clrt::Check("clFinish", [&] { ctx_.queue().finish(); });
    GenerationTally tally;
    tally.start = Clock::now();
    tally.hostBefore = query_->Stats().hostSeconds;
    tally.testsBefore = stats_.intersectionTests;
    if (!HitsFromSource(generation)) {
        query_->BeginGeneration(generation, rays_.pages[0].rays, uint32_t(std::min(batch_, nRays)),
                                timer_);
    }
    return tally;
}

// Into the pages EyePages took.
void Frame::GenerateEyeRays(size_t nRays) {
    for (size_t page = 0; page < rays_.pages.size(); ++page) {
        const size_t first = page * batch_;
        const uint32_t n = uint32_t(std::min(batch_, nRays - first));
        SetArgs(eyeKernel_, camBuffer_, uint32_t(first), n, rays_.pages[page].rays);
        Launch(ctx_, eyeKernel_, n, timer_);
    }
}

// The query's host work on page `page` (on the worker thread). Eye rays with float directions
// come with their camera, so the query need not read them back.
std::unique_ptr<PreparedBatch> Frame::Prepare(uint32_t generation, size_t nRays, size_t page) {
    if (HitsFromSource(generation)) return nullptr;
    RaySource source;
    if (generation == 0 && options_.rayEncoding != RayEncoding::kPolar16) {
        source.camera = &cam_;
        source.firstPixel = uint32_t(page * batch_);
    }
    return query_->Prepare(rays_.pages[page].rays,
                           uint32_t(std::min(batch_, nRays - page * batch_)), readQueue_, source);
}

// Intersect, shade, occlude, accumulate, compact.
void Frame::TraceBatch(const Batch& b, std::unique_ptr<PreparedBatch> prepared,
                       GenerationTally& tally) {
    if (!Intersect(b, std::move(prepared)).shaded) Shade(b);
    ShadowSlots shadow(ctx_.queue(), buffers_.shade.shadow, size_t(b.n) * params_.nLights);
    SpawnedRays spawned(ctx_.queue(), buffers_.shade, b.n);
    // The live slots and their order need none of the shadow query's answers: a worker finds
    // them while this thread classifies and queries the shadow rays.
    auto listed = std::async(std::launch::async, [&] { ListLive(b, spawned, tally); });
    Occlude(shadow);
    BatchOutputs out(ctx_.queue(), buffers_, b.n, params_.nLights,
                     b.generation == 0 && options_.aovs);
    listed.get();
    Accumulate(b, shadow, out, tally);
    shadow.Unmap();
    out.Unmap();
    spawned.Unmap();
    Compact(b);
    tally.stats.rays += b.n;
}

// The batch's nearest hits: the eye-hit source's for generation 0 where there is one, else the
// query's.
QueryResult Frame::Intersect(const Batch& b, std::unique_ptr<PreparedBatch> prepared) {
    const RayBuffers& rays = rays_.pages[b.page];
    ShadeBuffers& shade = buffers_.shade;
    // Eye rays have no infos (rc_types.h): the shading kernels take a null buffer for theirs.
    shade.rayInfo = b.generation == 0 ? cl::Buffer() : rays.info;
    shade.writeNormals = b.generation == 0 && options_.aovs;
    QueryResult found;
    if (newton_) newton_->Sample(rays.rays, b.n);
    if (HitsFromSource(b.generation)) {
        clrt::Check("clEnqueueWriteBuffer", [&] {
            ctx_.queue().enqueueWriteBuffer(buffers_.hits, CL_FALSE, 0, b.n * sizeof(RcHit),
                                            eyeHits_.data() + b.first);
        });
    } else {
        found = query_->Intersect(rays.rays, b.n, prepared.get(), buffers_.hits, shade, timer_);
        query_->Recycle(std::move(prepared));
    }
    stats_.intersectionTests += found.tests;
    return found;
}

// Shading of the batch's hits, for queries whose kernels do not shade: radiance, normals, the
// shadow slots and the secondary rays it spawns.
void Frame::Shade(const Batch& b) {
    const ShadeBuffers& shade = buffers_.shade;
    const SceneBuffers& s = sceneBuffers_;
    const cl::Buffer everyRay;  // no id list: the batch's rays [0, b.n)
    SetArgs(shadeKernel_, rays_.pages[b.page].rays, shade.rayInfo, buffers_.hits, everyRay, b.n,
            s.triangles, s.triangleShading, s.spheres, s.quadrics, s.materials, s.lights, s.params,
            shade.radiance, shade.NormalsOut(), shade.shadow.rays, shade.shadow.contribution,
            shade.secondary.rays, shade.secondary.info, shade.spawned);
    Launch(ctx_, shadeKernel_, PacketItems(b.n), timer_);
}

void Frame::Occlude(const ShadowSlots& shadow) {
    stats_.intersectionTests +=
        query_->Occluded(buffers_.shade.shadow.rays, shadow.rays.span(), buffers_.blocked, timer_);
}

// Lists the batch's live secondary slots, whose rays carry their pixel into the next generation,
// and orders them by RayOrder while every pixel has at most one ray in a generation (a pixel's
// contributions then arrive in generation order whatever the order of the rays).
void Frame::ListLive(const Batch& b, const SpawnedRays& spawned, GenerationTally& tally) {
    const auto t0 = Clock::now();
    const uint8_t* flags = spawned.flags.data();
    const size_t count = next_.pixels.size();  // rays listed before this batch's
    live_.clear();
    for (uint32_t i = 0; i < b.n; ++i) {
        branched_ |= flags[2 * size_t(i)] && flags[2 * size_t(i) + 1];
        for (uint32_t k = 0; k < 2; ++k) {
            if (!flags[2 * size_t(i) + k]) continue;
            live_.push_back(RC_SECONDARY_SLOT(i, k));
            next_.pixels.push_back(PixelOf(b, i));
            ++(k == 0 ? tally.reflection : tally.refraction);
        }
    }
    if (!branched_ && live_.size() > 1) {
        order_.Sort(spawned.rays.span(), live_, std::span(next_.pixels).subspan(count));
    }
    listSeconds_ += SecondsSince(t0);
}

// Adds the batch's radiance and unblocked shadow contributions to its pixels, in ray order (so a
// render is reproducible bit for bit), and writes the first-hit layers. While the generation's
// pixels all differ, two threads add a half of the rays each: no pixel gets sums from both.
void Frame::Accumulate(const Batch& b, const ShadowSlots& shadow, const BatchOutputs& out,
                       GenerationTally& tally) {
    const auto t0 = Clock::now();
    uint64_t shadowRays[2] = {0, 0};
    auto add = [&](size_t begin, size_t end) {
        shadowRays[begin == 0 ? 0 : 1] = AccumulateRange(b, shadow, out, begin, end);
    };
    if (pixelsDiffer_) {
        InTwoHalves(b.n, kParallelAccumulate, add);
    } else {
        add(0, b.n);
    }
    tally.stats.shadowRays += shadowRays[0] + shadowRays[1];
    hostSeconds_ += SecondsSince(t0);
}

// Accumulate's work on rays [begin, end); returns the shadow rays counted.
uint64_t Frame::AccumulateRange(const Batch& b, const ShadowSlots& shadow, const BatchOutputs& out,
                                size_t begin, size_t end) {
    const uint32_t nLights = params_.nLights;
    const rc_float4 *radiance = out.radiance.data(), *contribution = shadow.contribution.data();
    const uint8_t* blocked = out.blocked.data();
    const RcHit* hits = out.hits.data();  // null: no first-hit layers from this batch
    uint64_t shadowRays = 0;
    for (size_t i = begin; i < end; ++i) {
        const uint32_t pixel = PixelOf(b, i);
        // Once ordered, a generation's rays visit their pixels at random: the pixel a few rays
        // ahead is fetched while this one is added.
        if (b.generation > 0 && i + kPixelsAhead < end) {
            __builtin_prefetch(&img_.rgb[rays_.pixels[b.first + i + kPixelsAhead]], 1);
        }
        glm::vec3& px = img_.rgb[pixel];
        px += glm::vec3(radiance[i].x, radiance[i].y, radiance[i].z);
        for (uint32_t l = 0; l < nLights; ++l) {
            const rc_float4& c = contribution[i * nLights + l];
            if (c.w == 0.0f) continue;
            ++shadowRays;
            if (!blocked[i * nLights + l]) px += glm::vec3(c.x, c.y, c.z);
        }
        if (hits) {
            img_.id[pixel] = hits[i].prim;
            img_.depth[pixel] = hits[i].t;
            const rc_float4& n = out.normals.data()[i];
            img_.normal[pixel] = glm::vec3(n.x, n.y, n.z);
        }
    }
    return shadowRays;
}

// Copies the batch's live secondary rays, in ListLive's order, to the end of the next
// generation's pages (new pages from the pool). The batch's own page, answered and shaded, goes
// back to the pool first: the next page taken is then one whose ray pages were written before,
// not a fresh one.
void Frame::Compact(const Batch& b) {
    pool_.Give(rays_.pages[b.page]);
    const size_t pageRays = pool_.PageRays();
    const size_t count = next_.pixels.size() - live_.size();  // rays on the pages before these
    const RayBuffers& secondary = buffers_.shade.secondary;
    if (!live_.empty()) {
        clrt::Check("clEnqueueWriteBuffer", [&] {
            ctx_.queue().enqueueWriteBuffer(buffers_.liveSlots, CL_FALSE, 0,
                                            live_.size() * sizeof(uint32_t), live_.data());
        });
    }
    for (size_t done = 0; done < live_.size();) {
        const size_t offset = (count + done) % pageRays;
        if (offset == 0) next_.pages.push_back(pool_.Take());
        const uint32_t m = uint32_t(std::min(live_.size() - done, pageRays - offset));
        SetArgs(compactKernel_, secondary.rays, secondary.info, buffers_.liveSlots, uint32_t(done),
                m, next_.pages.back().rays, next_.pages.back().info, uint32_t(offset));
        Launch(ctx_, compactKernel_, m, timer_);
        done += m;
    }
}

// A progress line on stderr, at most once a second.
void Frame::ReportProgress(const Batch& b, size_t nRays) {
    if (!options_.progress || SecondsSince(lastProgress_) <= 1.0) return;
    std::fprintf(stderr, "\rrayclass: generation %u, %zu of %zu rays", b.generation, b.first + b.n,
                 nRays);
    lastProgress_ = Clock::now();
    printedProgress_ = true;
}

// The generation's counts into the stats; the rays it spawned become the generation in flight.
void Frame::EndGeneration(uint32_t generation, GenerationTally& tally) {
    GenerationStats& gen = tally.stats;
    if (generation == 0) stats_.raysByKind["eye"] += gen.rays;
    stats_.raysByKind["reflection"] += tally.reflection;
    stats_.raysByKind["refraction"] += tally.refraction;
    gen.spawned = next_.pixels.size();
    gen.seconds = SecondsSince(tally.start);
    gen.hostClassifySeconds = query_->Stats().hostSeconds - tally.hostBefore;
    gen.intersectionTests = stats_.intersectionTests - tally.testsBefore;
    query_->DescribeGeneration(gen);
    if (HitsFromSource(generation)) gen.query = eyeHitSource_->Name();
    stats_.raysByKind["shadow"] += gen.shadowRays;
    stats_.generations.push_back(gen);
    std::swap(rays_, next_);
}

image::Image Frame::Finish(Clock::time_point tStart) {
    const QueryStats q = query_->Stats();
    AddKernelTimes(timer_, q, stats_);
    stats_.shadowRaysFromLight = q.shadowRaysFromLight;
    stats_.shadowRaysInCells = q.shadowRaysInCells;
    stats_.eyeRaysFromCamera = q.eyeRaysFromCamera;
    stats_.accelStats = q.accel;
    stats_.timeS["host"] = hostSeconds_;
    stats_.timeS["host_live_thread"] = listSeconds_;
    if (options_.accel == Accel::kClassify || options_.accel == Accel::kAuto) {
        stats_.timeS["host_classify"] = q.hostSeconds;
    }
    stats_.timeS["render"] = SecondsSince(tStart);
    AddOtherTime(timer_, hostSeconds_ + q.hostSeconds, stats_);
    if (newton_) {
        const auto t0 = Clock::now();
        stats_.patchNewton = newton_->Count().ToStats();
        stats_.timeS["patch_newton_stats"] = SecondsSince(t0);
    }
    return std::move(img_);
}

}  // namespace

ClRenderer::ClRenderer(clrt::Context& ctx, const scene::Scene& scene, const RenderOptions& options,
                       EyeHitSource* eyeHits, QueryWrapper wrapQuery)
    : ctx_(ctx),
      scene_(scene),
      options_(options),
      eyeHits_(eyeHits),
      wrapQuery_(std::move(wrapQuery)) {}

void ClRenderer::UseProgram(FrameProgram program) {
    if (!ServesFrame(ctx_, program, options_)) {
        throw std::invalid_argument("UseProgram: a program built for other render options");
    }
    program_ = [program = std::move(program)] { return program; };
}

void ClRenderer::AwaitProgram(ProgramSource program) {
    program_ = [&ctx = ctx_, options = options_, program = std::move(program)] {
        FrameProgram out = program();
        if (!ServesFrame(ctx, out, options)) {
            throw std::invalid_argument("AwaitProgram: a program built for other render options");
        }
        return out;
    };
}

image::Image ClRenderer::Render(RenderStats& stats) {
    const auto tStart = Clock::now();
    Frame frame(ctx_, scene_, options_, program_, eyeHits_, wrapQuery_, stats);
    frame.Trace();
    return frame.Finish(tStart);
}

}  // namespace rayclass::render
