#include "rayclass/render/cl_renderer.h"

#include <chrono>
#include <cstdio>
#include <future>

#include "rayclass/classify/params.h"
#include "rayclass/clrt/mapped.h"
#include "rayclass/render/auto_query.h"
#include "rayclass/render/brute_query.h"
#include "rayclass/render/bvh_query.h"
#include "rayclass/render/classified_query.h"
#include "rayclass/render/launch.h"

namespace rayclass::render {

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::string KernelBuildOptions(const RenderOptions& options) {
    std::string out;
    for (const std::string& option :
         {std::string(options.triangleTest == TriangleTest::kWatertight ? "-DRC_WATERTIGHT=1" : ""),
          std::string(options.rayEncoding == RayEncoding::kPolar16 ? "-DRC_POLAR16" : ""),
          options.buildOptions}) {
        if (option.empty()) continue;
        out += (out.empty() ? "" : " ") + option;
    }
    return out;
}

RcRenderParams MakeRenderParams(const scene::Scene& scene, const RenderOptions& options) {
    RcRenderParams params{};
    params.nTriangles = uint32_t(scene.triangles.size());
    params.nSpheres = uint32_t(scene.spheres.size());
    params.nQuadrics = uint32_t(scene.quadrics.size());
    params.nLights = uint32_t(scene.lights.size());
    params.maxDepth = options.maxDepth;
    params.minWeight = options.minWeight;
    params.ambient = {scene.ambient.x, scene.ambient.y, scene.ambient.z, 0.0f};
    params.background = {scene.background.x, scene.background.y, scene.background.z, 0.0f};
    return params;
}

// The ray query options.accel names; its construction time goes into stats.
std::unique_ptr<RayQuery> MakeQuery(clrt::Context& ctx, const cl::Program& program,
                                    const SceneBuffers& buffers, const scene::Scene& scene,
                                    const RenderOptions& options, RenderStats& stats) {
    if (options.accel == Accel::kBrute) return MakeBruteForceQuery(ctx, program, buffers);
    // The caller keeps ctx, program, buffers, scene and stats alive longer than the query.
    auto makeBvh = [&ctx, &program, &buffers, &scene, &stats] {
        const auto t0 = Clock::now();
        auto query = MakeBvhQuery(ctx, program, buffers, scene);
        stats.timeS["bvh_build"] = SecondsSince(t0);
        return query;
    };
    if (options.accel == Accel::kBvh) return makeBvh();
    const auto t0 = Clock::now();
    classify::Params params = classify::Params::ForScene(scene);
    for (const classify::ParamSetting& setting : options.classifyParams) setting.ApplyTo(params);
    // The 16-lane kernels are Moeller-Trumbore only: the watertight test runs the scalar style.
    const KernelStyle style =
        options.triangleTest == TriangleTest::kWatertight ? KernelStyle::kScalar : options.kernel;
    auto query = MakeClassifiedQuery(ctx, program, buffers, scene, params, style);
    stats.timeS["classify_setup"] = SecondsSince(t0);
    if (options.accel == Accel::kAuto) return MakeAutoQuery(ctx, std::move(query), makeBvh);
    return query;
}

// Kernel times, query time and what no timer covers, once the render is done.
void FinishStats(RenderStats& stats, const KernelTimer& timer, const RayQuery& query, Accel accel,
                 double hostSeconds, Clock::time_point tStart) {
    const auto& ks = timer.Seconds();
    for (const auto& [name, s] : ks) stats.timeS["kernel_" + name] = s;
    const QueryStats q = query.Stats();
    stats.queryTimeS = q.hostSeconds;
    stats.shadowRaysFromLight = q.shadowRaysFromLight;
    stats.shadowRaysInCells = q.shadowRaysInCells;
    stats.eyeRaysFromCamera = q.eyeRaysFromCamera;
    for (const auto& [name, seconds] : ks) {
        if (name.starts_with("rc_query") || name.starts_with("rc_occluded") ||
            name.starts_with("rc_intersect") || name == "rc_gather_blocks") {
            stats.queryTimeS += seconds;
        }
    }
    stats.timeS["host"] = hostSeconds;
    if (accel == Accel::kClassify || accel == Accel::kAuto) {
        stats.timeS["host_classify"] = q.hostSeconds;
    }
    stats.timeS["render"] = SecondsSince(tStart);
    // What neither the kernels' profiling nor the host timers cover: copies between host and
    // device, buffer allocation, launch overhead and waiting.
    double accounted = hostSeconds + q.hostSeconds;
    for (const auto& [key, seconds] : stats.timeS) {
        if (key == "program_build" || key == "classify_setup" || key == "bvh_build" ||
            key.starts_with("eye_hits_")) {
            accounted += seconds;
        }
    }
    for (const auto& [name, seconds] : ks) accounted += seconds;
    stats.timeS["transfer_and_other"] = std::max(0.0, stats.timeS["render"] - accounted);
}

// Device pages of rays (both arrays), recycled from generation to generation: a fresh buffer
// costs its page faults again.
class PagePool {
  public:
    PagePool(clrt::Context& ctx, size_t pageRays) : ctx_(ctx), pageRays_(pageRays) {}
    size_t PageRays() const { return pageRays_; }
    RayBuffers Take() {
        if (free_.empty()) {
            return {DeviceBuffer(ctx_, pageRays_ * sizeof(RcRay)),
                    DeviceBuffer(ctx_, pageRays_ * sizeof(RcRayInfo))};
        }
        RayBuffers page = std::move(free_.back());
        free_.pop_back();
        return page;
    }
    void Give(RayBuffers& page) {
        if (page.rays()) free_.push_back(std::move(page));
        page = RayBuffers();
    }
    void Give(std::vector<RayBuffers>& pages) {
        for (RayBuffers& page : pages) Give(page);
        pages.clear();
    }

  private:
    clrt::Context& ctx_;
    size_t pageRays_;
    std::vector<RayBuffers> free_;
};

// Copies the live secondary slots `live` (indices into `secondary`, in slot order) to the end
// of `pages`, which hold `count` rays; new pages come from `pool`.
void AppendToPages(clrt::Context& ctx, cl::Kernel& compact, const RayBuffers& secondary,
                   const cl::Buffer& liveSlots, const std::vector<uint32_t>& live, size_t count,
                   PagePool& pool, std::vector<RayBuffers>& pages, KernelTimer& timer) {
    const size_t pageRays = pool.PageRays();
    if (live.empty()) return;
    clrt::Check("clEnqueueWriteBuffer", [&] {
        ctx.queue().enqueueWriteBuffer(liveSlots, CL_FALSE, 0, live.size() * sizeof(uint32_t),
                                       live.data());
    });
    for (size_t done = 0; done < live.size();) {
        const size_t offset = (count + done) % pageRays;
        if (offset == 0) pages.push_back(pool.Take());
        const uint32_t m = uint32_t(std::min(live.size() - done, pageRays - offset));
        SetArgs(compact, secondary.rays, secondary.info, liveSlots, uint32_t(done), m,
                pages.back().rays, pages.back().info, uint32_t(offset));
        Launch(ctx, compact, m, timer);
        done += m;
    }
}

}  // namespace

ClRenderer::ClRenderer(clrt::Context& ctx, const scene::Scene& scene, const RenderOptions& options,
                       EyeHitSource* eyeHits)
    : ctx_(ctx), scene_(scene), options_(options), eyeHits_(eyeHits) {}

image::Image ClRenderer::Render(RenderStats& stats) {
    const auto tStart = Clock::now();
    const CameraBasis basis(scene_.camera);
    const uint32_t width = basis.width, height = basis.height;
    image::Image img(width, height);
    if (options_.aovs) {
        img.depth.assign(img.PixelCount(), std::numeric_limits<float>::infinity());
        img.id.assign(img.PixelCount(), RC_NO_HIT);
        img.normal.assign(img.PixelCount(), glm::vec3(0.0f));
    }
    stats.width = width;
    stats.height = height;
    stats.device = ctx_.info().name;
    stats.nPrimitives = scene_.PrimitiveCount();

    auto t0 = Clock::now();
    const cl::Program program =
        BuildRenderProgram(ctx_, KernelBuildOptions(options_), &stats.programFromCache);
    stats.timeS["program_build"] = SecondsSince(t0);

    const RcRenderParams params = MakeRenderParams(scene_, options_);
    const SceneBuffers sceneBuffers(ctx_, scene_, params);
    const std::unique_ptr<RayQuery> query =
        MakeQuery(ctx_, program, sceneBuffers, scene_, options_, stats);
    stats.accel = query->Name();
    stats.eyeRays = eyeHits_ ? eyeHits_->Name() : "kernel";

    const RcCamera cam = basis.ToDevice();
    const cl::Buffer camBuffer = UploadVector(ctx_, std::vector<RcCamera>{cam});
    cl::Kernel eyeKernel(program, "rc_generate_eye_rays");
    cl::Kernel shadeKernel(program, "rc_shade");

    const uint32_t nLights = params.nLights;
    // Later generations are split into batches of the same size, so no buffer need be larger
    // than the image.
    const size_t batch = BatchRays(options_.batchRays, size_t(width) * height, params.nLights,
                                   ctx_.info().maxAllocBytes);
    // Per batch: the query's hits, the shading kernel's outputs.
    cl::Buffer hits = DeviceBuffer(ctx_, batch * sizeof(RcHit));
    ShadeBuffers shade = MakeShadeBuffers(ctx_, batch, nLights);
    const cl::Buffer &radiance = shade.radiance, &normals = shade.normals, &spawned = shade.spawned;
    const ShadowBuffers& shadow = shade.shadow;
    const RayBuffers& secondary = shade.secondary;
    cl::Buffer blocked = DeviceBuffer(ctx_, batch * nLights);
    cl::Buffer liveSlots = DeviceBuffer(ctx_, 2 * batch * sizeof(uint32_t));
    cl::Kernel compactKernel(program, "rc_compact_rays");

    std::vector<uint32_t> hostLive;

    // A generation's rays live on the device in pages of `batch` rays; a batch is one page. The
    // host keeps only each ray's pixel, for accumulating contributions.
    std::vector<RayBuffers> pages, nextPages;
    PagePool pool(ctx_, batch);
    std::vector<uint32_t> pixels, nextPixels;
    auto& q = ctx_.queue();
    cl::CommandQueue readQueue = clrt::Check(
        "clCreateCommandQueue", [&] { return cl::CommandQueue(ctx_.context(), ctx_.device()); });

    KernelTimer timer;
    double hostSeconds = 0;
    const size_t nEye = size_t(width) * height;
    // Generation 0's hits from another source (the raster pass), uploaded batch by batch below.
    std::vector<RcHit> eyeHits;
    if (eyeHits_) {
        t0 = Clock::now();
        eyeHits = eyeHits_->FindHits(scene_, basis, stats);
        stats.timeS["eye_hits_" + eyeHits_->Name()] = SecondsSince(t0);
    }
    auto lastProgress = Clock::now();
    bool printedProgress = false;

    for (uint32_t generation = 0;; ++generation) {
        const size_t nRays = generation == 0 ? nEye : pixels.size();
        if (nRays == 0) break;
        GenerationStats gen;
        pool.Give(nextPages);
        nextPixels.clear();
        uint64_t nReflection = 0, nRefraction = 0;
        if (generation == 0) {
            for (size_t first = 0; first < nRays; first += batch) {
                const uint32_t n = uint32_t(std::min(batch, nRays - first));
                pages.push_back(pool.Take());
                SetArgs(eyeKernel, camBuffer, uint32_t(first), n, pages.back().rays);
                Launch(ctx_, eyeKernel, n, timer);
            }
        }
        // The pages are complete: a worker reads batch k + 1 back and classifies it while the
        // device queries and shades batch k.
        clrt::Check("clFinish", [&] { q.finish(); });
        const auto tGeneration = Clock::now();
        const double hostBefore = query->Stats().hostSeconds;
        const uint64_t testsBefore = stats.intersectionTests;
        if (!(generation == 0 && eyeHits_)) {
            query->BeginGeneration(generation, pages[0].rays, uint32_t(std::min(batch, nRays)),
                                   timer);
        }
        auto prepare = [&](size_t page) -> std::unique_ptr<PreparedBatch> {
            if (generation == 0 && eyeHits_) return nullptr;
            RaySource source;
            if (generation == 0 && options_.rayEncoding != RayEncoding::kPolar16) {
                source.camera = &cam;
                source.firstPixel = uint32_t(page * batch);
            }
            return query->Prepare(pages[page].rays, uint32_t(std::min(batch, nRays - page * batch)),
                                  readQueue, source);
        };
        std::future<std::unique_ptr<PreparedBatch>> nextPrepared =
            std::async(std::launch::async, prepare, 0);
        for (size_t first = 0, page = 0; first < nRays; first += batch, ++page) {
            const uint32_t n = uint32_t(std::min(batch, nRays - first));
            std::unique_ptr<PreparedBatch> prepared = nextPrepared.get();
            if (first + batch < nRays) {
                nextPrepared = std::async(std::launch::async, prepare, page + 1);
            }
            const RayBuffers& rays = pages[page];
            // Eye rays have no infos (rc_types.h): the shading kernels take a null buffer for
            // theirs.
            shade.rayInfo = generation == 0 ? cl::Buffer() : rays.info;
            shade.writeNormals = generation == 0 && options_.aovs;
            QueryResult found;
            if (generation == 0 && eyeHits_) {
                clrt::Check("clEnqueueWriteBuffer", [&] {
                    q.enqueueWriteBuffer(hits, CL_FALSE, 0, n * sizeof(RcHit),
                                         eyeHits.data() + first);
                });
            } else {
                found = query->Intersect(rays.rays, n, prepared.get(), hits, shade, timer);
                query->Recycle(std::move(prepared));
            }
            stats.intersectionTests += found.tests;
            if (!found.shaded) {
                SetArgs(shadeKernel, rays.rays, shade.rayInfo, hits, n, sceneBuffers.triangles,
                        sceneBuffers.triangleShading, sceneBuffers.spheres, sceneBuffers.quadrics,
                        sceneBuffers.materials, sceneBuffers.lights, sceneBuffers.params, radiance,
                        shade.NormalsOut(), shadow.rays, shadow.contribution, secondary.rays,
                        secondary.info, spawned);
                Launch(ctx_, shadeKernel, n, timer);
            }
            // The rays are read in place by the shadow query's classification, the contributions
            // by the accumulation below.
            const uint32_t nShadow = n * nLights;
            clrt::MappedRead<RcRay> shadowRays(q, shadow.rays, nShadow);
            clrt::MappedRead<rc_float4> shadowContribution(q, shadow.contribution, nShadow);
            const rc_float4* hostContribution = shadowContribution.data();
            stats.intersectionTests +=
                query->Occluded(shadow.rays, shadowRays.span(), blocked, timer);
            // The batch's outputs are read in place too: copies into host arrays would fault in
            // their pages again in every one-frame render.
            clrt::MappedRead<rc_float4> hostRadiance(q, radiance, n);
            clrt::MappedRead<uint8_t> hostBlocked(q, blocked, nShadow);
            clrt::MappedRead<uint8_t> hostSpawned(q, spawned, 2 * size_t(n));
            const bool readAovs = generation == 0 && options_.aovs;
            clrt::MappedRead<RcHit> hostHits(q, hits, readAovs ? n : 0);
            clrt::MappedRead<rc_float4> hostNormals(q, normals, readAovs ? n : 0);
            const rc_float4* radianceOf = hostRadiance.data();
            const uint8_t *blockedOf = hostBlocked.data(), *spawnedOf = hostSpawned.data();
            const RcHit* hitOf = hostHits.data();
            const rc_float4* normalOf = hostNormals.data();

            const auto tHost = Clock::now();
            auto pixelOf = [&](uint32_t i) {
                return generation == 0 ? uint32_t(first + i) : pixels[first + i];
            };
            hostLive.clear();
            for (uint32_t i = 0; i < n; ++i) {
                const uint32_t pixel = pixelOf(i);
                glm::vec3& px = img.rgb[pixel];
                px += glm::vec3(radianceOf[i].x, radianceOf[i].y, radianceOf[i].z);
                for (uint32_t l = 0; l < nLights; ++l) {
                    const rc_float4& c = hostContribution[size_t(i) * nLights + l];
                    if (c.w == 0.0f) continue;
                    ++gen.shadowRays;
                    if (!blockedOf[size_t(i) * nLights + l]) {
                        px += glm::vec3(c.x, c.y, c.z);
                    }
                }
                for (uint32_t k = 0; k < 2; ++k) {
                    if (!spawnedOf[2 * size_t(i) + k]) continue;
                    hostLive.push_back(2 * i + k);
                    nextPixels.push_back(pixel);
                    ++(k == 0 ? nReflection : nRefraction);
                }
                if (readAovs) {
                    img.id[pixel] = hitOf[i].prim;
                    img.depth[pixel] = hitOf[i].t;
                    img.normal[pixel] = glm::vec3(normalOf[i].x, normalOf[i].y, normalOf[i].z);
                }
            }
            hostSeconds += SecondsSince(tHost);
            // Before the next batch's shading writes the buffers.
            shadowRays.Unmap();
            shadowContribution.Unmap();
            hostRadiance.Unmap();
            hostBlocked.Unmap();
            hostSpawned.Unmap();
            hostHits.Unmap();
            hostNormals.Unmap();

            AppendToPages(ctx_, compactKernel, secondary, liveSlots, hostLive,
                          nextPixels.size() - hostLive.size(), pool, nextPages, timer);
            // The batch's rays are answered and shaded: the next generation can fill their page.
            pool.Give(pages[page]);
            gen.rays += n;

            if (options_.progress && SecondsSince(lastProgress) > 1.0) {
                std::fprintf(stderr, "\rrayclass: generation %u, %zu of %zu rays", generation,
                             first + n, nRays);
                lastProgress = Clock::now();
                printedProgress = true;
            }
        }
        if (generation == 0) stats.raysByKind["eye"] += gen.rays;
        stats.raysByKind["reflection"] += nReflection;
        stats.raysByKind["refraction"] += nRefraction;
        gen.spawned = nextPixels.size();
        gen.seconds = SecondsSince(tGeneration);
        gen.hostClassifySeconds = query->Stats().hostSeconds - hostBefore;
        gen.intersectionTests = stats.intersectionTests - testsBefore;
        query->DescribeGeneration(gen);
        if (generation == 0 && eyeHits_) gen.query = eyeHits_->Name();
        stats.raysByKind["shadow"] += gen.shadowRays;
        stats.generations.push_back(gen);
        std::swap(pages, nextPages);
        std::swap(pixels, nextPixels);
    }
    if (printedProgress) std::fprintf(stderr, "\n");

    FinishStats(stats, timer, *query, options_.accel, hostSeconds, tStart);
    return img;
}

}  // namespace rayclass::render
