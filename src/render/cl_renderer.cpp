#include "rayclass/render/cl_renderer.h"

#include <chrono>
#include <cstdio>

namespace rayclass::render {

namespace {

constexpr size_t kLocalSize = 64;

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

template <typename T>
cl::Buffer UploadVector(clrt::Context& ctx, const std::vector<T>& v) {
    // OpenCL rejects zero-sized buffers: an empty list still gets one element.
    const size_t bytes = std::max<size_t>(1, v.size()) * sizeof(T);
    return clrt::Check("clCreateBuffer", [&] {
        return cl::Buffer(ctx.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, bytes,
                          v.empty() ? std::vector<T>(1).data() : const_cast<T*>(v.data()));
    });
}

cl::Buffer DeviceBuffer(clrt::Context& ctx, size_t bytes) {
    return clrt::Check("clCreateBuffer", [&] {
        return cl::Buffer(ctx.context(), CL_MEM_READ_WRITE, std::max<size_t>(1, bytes));
    });
}

void Launch(clrt::Context& ctx, cl::Kernel& kernel, size_t n, KernelTimer& timer) {
    if (n == 0) return;
    cl::Event event;
    clrt::Check("clEnqueueNDRangeKernel", [&] {
        ctx.queue().enqueueNDRangeKernel(kernel, cl::NullRange,
                                         cl::NDRange(clrt::RoundUp(n, kLocalSize)),
                                         cl::NDRange(kLocalSize), nullptr, &event);
    });
    timer.Record(kernel.getInfo<CL_KERNEL_FUNCTION_NAME>(), event);
}

class BruteForceQuery final : public RayQuery {
public:
    BruteForceQuery(clrt::Context& ctx, const cl::Program& program, const SceneBuffers& scene)
        : ctx_(ctx),
          scene_(scene),
          intersect_(program, "rc_intersect_brute"),
          occluded_(program, "rc_occluded_brute") {}

    std::string Name() const override { return "brute"; }

    uint64_t Intersect(const cl::Buffer& rays, uint32_t n, const cl::Buffer& hits,
                       KernelTimer& timer) override {
        clrt::Check("clSetKernelArg(rc_intersect_brute)", [&] {
            intersect_.setArg(0, rays);
            intersect_.setArg(1, n);
            intersect_.setArg(2, scene_.triangles);
            intersect_.setArg(3, scene_.spheres);
            intersect_.setArg(4, scene_.quadrics);
            intersect_.setArg(5, scene_.params);
            intersect_.setArg(6, hits);
        });
        Launch(ctx_, intersect_, n, timer);
        const auto& p = scene_.hostParams;
        return uint64_t(n) * (p.nTriangles + p.nSpheres + p.nQuadrics);
    }

    uint64_t Occluded(const cl::Buffer& shadowRays, uint32_t n, const cl::Buffer& blocked,
                      KernelTimer& timer) override {
        if (tests_.size() < n) {
            tests_.resize(n);
            testsBuffer_ = DeviceBuffer(ctx_, n * sizeof(uint32_t));
        }
        clrt::Check("clSetKernelArg(rc_occluded_brute)", [&] {
            occluded_.setArg(0, shadowRays);
            occluded_.setArg(1, n);
            occluded_.setArg(2, scene_.triangles);
            occluded_.setArg(3, scene_.spheres);
            occluded_.setArg(4, scene_.quadrics);
            occluded_.setArg(5, scene_.params);
            occluded_.setArg(6, blocked);
            occluded_.setArg(7, testsBuffer_);
        });
        Launch(ctx_, occluded_, n, timer);
        if (n == 0) return 0;
        clrt::Check("clEnqueueReadBuffer", [&] {
            ctx_.queue().enqueueReadBuffer(testsBuffer_, CL_TRUE, 0, n * sizeof(uint32_t),
                                           tests_.data());
        });
        uint64_t total = 0;
        for (uint32_t i = 0; i < n; ++i) total += tests_[i];
        return total;
    }

private:
    clrt::Context& ctx_;
    const SceneBuffers& scene_;
    cl::Kernel intersect_, occluded_;
    cl::Buffer testsBuffer_;
    std::vector<uint32_t> tests_;
};

const char* KindName(rc_uint kind) {
    switch (kind) {
        case RC_RAY_EYE:
            return "eye";
        case RC_RAY_REFLECTION:
            return "reflection";
        case RC_RAY_REFRACTION:
            return "refraction";
        default:
            return "shadow";
    }
}

}  // namespace

void KernelTimer::Record(const std::string& kernel, const cl::Event& event) {
    event.wait();
    const auto start = event.getProfilingInfo<CL_PROFILING_COMMAND_START>();
    const auto end = event.getProfilingInfo<CL_PROFILING_COMMAND_END>();
    seconds_[kernel] += double(end - start) * 1e-9;
}

SceneBuffers::SceneBuffers(clrt::Context& ctx, const DeviceScene& scene,
                           const RcRenderParams& renderParams)
    : hostParams(renderParams) {
    triangles = UploadVector(ctx, scene.triangles);
    triangleShading = UploadVector(ctx, scene.triangleShading);
    spheres = UploadVector(ctx, scene.spheres);
    quadrics = UploadVector(ctx, scene.quadrics);
    materials = UploadVector(ctx, scene.materials);
    lights = UploadVector(ctx, scene.lights);
    params = UploadVector(ctx, std::vector<RcRenderParams>{hostParams});
}

std::unique_ptr<RayQuery> MakeBruteForceQuery(clrt::Context& ctx, const cl::Program& program,
                                              const SceneBuffers& scene) {
    return std::make_unique<BruteForceQuery>(ctx, program, scene);
}

cl::Program BuildRenderProgram(const clrt::Context& ctx, const std::string& extraOptions) {
    const std::string options =
        "-cl-std=CL1.2 -DRC_LOCAL_SIZE=" + std::to_string(kLocalSize) +
        (extraOptions.empty() ? "" : " " + extraOptions);
    return ctx.BuildProgram({"camera.cl", "intersect.cl", "shade.cl", "brute.cl"}, options);
}

ClRenderer::ClRenderer(clrt::Context& ctx, const scene::Scene& scene,
                       const RenderOptions& options, EyeHitSource* eyeHits)
    : ctx_(ctx), scene_(scene), options_(options), eyeHits_(eyeHits) {
    if (options_.eyeRays != "kernel" && options_.eyeRays != "raster") {
        throw Error("unknown eye-ray path '" + options_.eyeRays + "' (use raster or kernel)");
    }
    if (options_.eyeRays == "kernel") eyeHits_ = nullptr;
    if (options_.eyeRays == "raster" && !eyeHits_) {
        throw Error("eye rays 'raster' need a raster pass (no OpenGL context was made)");
    }
}

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
    const cl::Program program = BuildRenderProgram(ctx_, options_.buildOptions);
    stats.timeS["program_build"] = SecondsSince(t0);

    RcRenderParams params{};
    params.nTriangles = uint32_t(scene_.triangles.size());
    params.nSpheres = uint32_t(scene_.spheres.size());
    params.nQuadrics = uint32_t(scene_.quadrics.size());
    params.nLights = uint32_t(scene_.lights.size());
    params.maxDepth = options_.maxDepth;
    params.minWeight = options_.minWeight;
    params.ambient = {scene_.ambient.x, scene_.ambient.y, scene_.ambient.z, 0.0f};
    params.background = {scene_.background.x, scene_.background.y, scene_.background.z, 0.0f};
    const DeviceScene deviceScene(scene_);
    const SceneBuffers sceneBuffers(ctx_, deviceScene, params);
    auto query = MakeBruteForceQuery(ctx_, program, sceneBuffers);
    stats.accel = query->Name();
    stats.eyeRays = eyeHits_ ? eyeHits_->Name() : "kernel";

    const RcCamera cam = basis.ToDevice();
    const cl::Buffer camBuffer = UploadVector(ctx_, std::vector<RcCamera>{cam});
    cl::Kernel eyeKernel(program, "rc_generate_eye_rays");
    cl::Kernel shadeKernel(program, "rc_shade");

    const uint32_t nLights = params.nLights;
    const size_t batch = std::max<uint32_t>(1, options_.batchRays);
    cl::Buffer rays = DeviceBuffer(ctx_, batch * sizeof(RcRay));
    cl::Buffer hits = DeviceBuffer(ctx_, batch * sizeof(RcHit));
    cl::Buffer radiance = DeviceBuffer(ctx_, batch * sizeof(rc_float4));
    cl::Buffer normals = DeviceBuffer(ctx_, batch * sizeof(rc_float4));
    cl::Buffer shadow = DeviceBuffer(ctx_, batch * nLights * sizeof(RcShadowRay));
    cl::Buffer blocked = DeviceBuffer(ctx_, batch * nLights);
    cl::Buffer secondary = DeviceBuffer(ctx_, 2 * batch * sizeof(RcRay));

    std::vector<RcHit> hostHits(batch);
    std::vector<rc_float4> hostRadiance(batch), hostNormals(batch);
    std::vector<RcShadowRay> hostShadow(batch * nLights);
    std::vector<uint8_t> hostBlocked(batch * nLights);
    std::vector<RcRay> hostSecondary(2 * batch);
    std::vector<RcRay> eyeBatch(batch);

    KernelTimer timer;
    double hostSeconds = 0;
    std::vector<RcRay> current, next;
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
        const size_t nRays = generation == 0 ? nEye : current.size();
        if (nRays == 0) break;
        GenerationStats gen;
        next.clear();
        for (size_t first = 0; first < nRays; first += batch) {
            const uint32_t n = uint32_t(std::min(batch, nRays - first));
            if (generation == 0) {
                clrt::Check("clSetKernelArg(rc_generate_eye_rays)", [&] {
                    eyeKernel.setArg(0, camBuffer);
                    eyeKernel.setArg(1, uint32_t(first));
                    eyeKernel.setArg(2, n);
                    eyeKernel.setArg(3, rays);
                });
                Launch(ctx_, eyeKernel, n, timer);
            } else {
                clrt::Check("clEnqueueWriteBuffer", [&] {
                    ctx_.queue().enqueueWriteBuffer(rays, CL_FALSE, 0, n * sizeof(RcRay),
                                                    current.data() + first);
                });
            }
            if (generation == 0 && eyeHits_) {
                clrt::Check("clEnqueueWriteBuffer", [&] {
                    ctx_.queue().enqueueWriteBuffer(hits, CL_FALSE, 0, n * sizeof(RcHit),
                                                    eyeHits.data() + first);
                });
            } else {
                stats.intersectionTests += query->Intersect(rays, n, hits, timer);
            }
            clrt::Check("clSetKernelArg(rc_shade)", [&] {
                int a = 0;
                shadeKernel.setArg(a++, rays);
                shadeKernel.setArg(a++, hits);
                shadeKernel.setArg(a++, n);
                shadeKernel.setArg(a++, sceneBuffers.triangles);
                shadeKernel.setArg(a++, sceneBuffers.triangleShading);
                shadeKernel.setArg(a++, sceneBuffers.spheres);
                shadeKernel.setArg(a++, sceneBuffers.quadrics);
                shadeKernel.setArg(a++, sceneBuffers.materials);
                shadeKernel.setArg(a++, sceneBuffers.lights);
                shadeKernel.setArg(a++, sceneBuffers.params);
                shadeKernel.setArg(a++, radiance);
                shadeKernel.setArg(a++, normals);
                shadeKernel.setArg(a++, shadow);
                shadeKernel.setArg(a++, secondary);
            });
            Launch(ctx_, shadeKernel, n, timer);
            const uint32_t nShadow = n * nLights;
            stats.intersectionTests += query->Occluded(shadow, nShadow, blocked, timer);

            auto& q = ctx_.queue();
            clrt::Check("clEnqueueReadBuffer", [&] {
                q.enqueueReadBuffer(radiance, CL_FALSE, 0, n * sizeof(rc_float4),
                                    hostRadiance.data());
                if (nShadow > 0) {
                    q.enqueueReadBuffer(shadow, CL_FALSE, 0, nShadow * sizeof(RcShadowRay),
                                        hostShadow.data());
                    q.enqueueReadBuffer(blocked, CL_FALSE, 0, nShadow, hostBlocked.data());
                }
                q.enqueueReadBuffer(secondary, CL_FALSE, 0, 2 * size_t(n) * sizeof(RcRay),
                                    hostSecondary.data());
                if (generation == 0) {
                    q.enqueueReadBuffer(hits, CL_FALSE, 0, n * sizeof(RcHit), hostHits.data());
                    q.enqueueReadBuffer(rays, CL_FALSE, 0, n * sizeof(RcRay), eyeBatch.data());
                    if (options_.aovs) {
                        q.enqueueReadBuffer(normals, CL_FALSE, 0, n * sizeof(rc_float4),
                                            hostNormals.data());
                    }
                }
                q.finish();
            });

            const auto tHost = Clock::now();
            const RcRay* batchRays = generation == 0 ? eyeBatch.data() : current.data() + first;
            for (uint32_t i = 0; i < n; ++i) {
                const RcRay& ray = batchRays[i];
                glm::vec3& px = img.rgb[ray.pixel];
                px += glm::vec3(hostRadiance[i].x, hostRadiance[i].y, hostRadiance[i].z);
                for (uint32_t l = 0; l < nLights; ++l) {
                    const RcShadowRay& s = hostShadow[size_t(i) * nLights + l];
                    if (s.contribution.w == 0.0f) continue;
                    ++gen.shadowRays;
                    if (!hostBlocked[size_t(i) * nLights + l]) {
                        px += glm::vec3(s.contribution.x, s.contribution.y, s.contribution.z);
                    }
                }
                for (int k = 0; k < 2; ++k) {
                    const RcRay& s = hostSecondary[2 * size_t(i) + k];
                    if (s.weight.w != 0.0f) next.push_back(s);
                }
                ++stats.raysByKind[KindName(ray.kind)];
                if (generation == 0 && options_.aovs) {
                    const RcHit& h = hostHits[i];
                    img.id[ray.pixel] = h.prim;
                    img.depth[ray.pixel] = h.t;
                    img.normal[ray.pixel] =
                        glm::vec3(hostNormals[i].x, hostNormals[i].y, hostNormals[i].z);
                }
            }
            gen.rays += n;
            hostSeconds += SecondsSince(tHost);

            if (options_.progress && SecondsSince(lastProgress) > 1.0) {
                std::fprintf(stderr, "\rrayclass: generation %u, %zu of %zu rays", generation,
                             first + n, nRays);
                lastProgress = Clock::now();
                printedProgress = true;
            }
        }
        gen.spawned = next.size();
        stats.raysByKind["shadow"] += gen.shadowRays;
        stats.generations.push_back(gen);
        std::swap(current, next);
    }
    if (printedProgress) std::fprintf(stderr, "\n");

    for (const auto& [name, s] : timer.Seconds()) stats.timeS["kernel_" + name] = s;
    const auto& ks = timer.Seconds();
    auto kernelTime = [&](const char* name) {
        auto it = ks.find(name);
        return it == ks.end() ? 0.0 : it->second;
    };
    stats.queryTimeS = kernelTime("rc_intersect_brute") + kernelTime("rc_occluded_brute");
    stats.timeS["host"] = hostSeconds;
    stats.timeS["render"] = SecondsSince(tStart);
    return img;
}

}  // namespace rayclass::render
