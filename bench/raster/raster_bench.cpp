// Raster eye-ray pass against the OpenCL brute-force eye-ray query: time per hull type, depth
// complexity (fragments per pixel), id mismatches. Prints one line per (scene, method).
//
//   build/bench/raster_bench [WIDTH HEIGHT] [SCENE...]
// SCENE: a scene file, or spheres:N for N random spheres. Default: scenes/cornell.json,
// spheres:1000, spheres:10000, spheres:100000, ../shared/scenes/conference.obj (when present).
// Environment as in the tests: POCL_MAX_PTHREAD_COUNT=2 is set unless given.
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "rayclass/clrt/context.h"
#include "rayclass/raster/raster_pass.h"
#include "rayclass/render/cl_renderer.h"
#include "rayclass/scene/loader.h"

using namespace rayclass;

namespace {

scene::Scene RandomSpheres(uint32_t n) {
    scene::Scene s;
    std::mt19937 rng(1234);
    std::uniform_real_distribution<float> pos(-10.0f, 10.0f);
    // Volume fraction about 5%: radius from n spheres filling 0.05 of the 20^3 cube.
    const float r = std::cbrt(0.05f * 8000.0f / (4.18879f * float(n)));
    std::uniform_real_distribution<float> rad(0.5f * r, 1.5f * r);
    for (uint32_t i = 0; i < n; ++i) s.spheres.push_back({{pos(rng), pos(rng), pos(rng)}, rad(rng)});
    s.camera.position = {0, 0, 30};
    s.camera.lookAt = {0, 0, 0};
    s.camera.fovYDegrees = 45;
    return s;
}

std::vector<RcHit> KernelHits(clrt::Context& ctx, const cl::Program& program,
                              const scene::Scene& scene, double& seconds) {
    RcRenderParams params{};
    params.nTriangles = uint32_t(scene.triangles.size());
    params.nSpheres = uint32_t(scene.spheres.size());
    params.nQuadrics = uint32_t(scene.quadrics.size());
    const render::DeviceScene device(scene);
    const render::SceneBuffers buffers(ctx, device, params);
    auto query = render::MakeBruteForceQuery(ctx, program, buffers);
    const RcCamera cam = render::CameraBasis(scene.camera).ToDevice();
    const uint32_t n = cam.width * cam.height;
    cl::Buffer camBuffer(ctx.context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof cam,
                         const_cast<RcCamera*>(&cam));
    cl::Buffer rays(ctx.context(), CL_MEM_READ_WRITE, n * sizeof(RcRay));
    cl::Buffer hits(ctx.context(), CL_MEM_READ_WRITE, n * sizeof(RcHit));
    cl::Kernel eye(program, "rc_generate_eye_rays");
    eye.setArg(0, camBuffer);
    eye.setArg(1, 0u);
    eye.setArg(2, n);
    eye.setArg(3, rays);
    ctx.queue().enqueueNDRangeKernel(eye, cl::NullRange, cl::NDRange(clrt::RoundUp(n, 64)),
                                     cl::NDRange(64));
    render::KernelTimer timer;
    // Brute force shades nothing itself: the shading buffers stay unused.
    query->Intersect(rays, n, nullptr, hits, render::ShadeBuffers{}, timer);
    seconds = timer.Seconds().at("rc_intersect_brute");
    std::vector<RcHit> out(n);
    ctx.queue().enqueueReadBuffer(hits, CL_TRUE, 0, n * sizeof(RcHit), out.data());
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    setenv("POCL_MAX_PTHREAD_COUNT", "2", 0);
    uint32_t width = 400, height = 300;
    int a = 1;
    if (argc >= 3 && std::isdigit(static_cast<unsigned char>(argv[1][0]))) {
        width = uint32_t(std::atoi(argv[1]));
        height = uint32_t(std::atoi(argv[2]));
        a = 3;
    }
    std::vector<std::string> scenes(argv + a, argv + argc);
    if (scenes.empty()) {
        const std::filesystem::path root = std::filesystem::path(RAYCLASS_BENCH_SOURCE_DIR);
        scenes = {(root / "scenes/cornell.json").string(), "spheres:1000", "spheres:10000",
                  "spheres:100000"};
        const auto conf = root / "../shared/scenes/conference.obj";
        if (std::filesystem::exists(conf)) scenes.push_back(conf.string());
    }
    try {
        std::string why;
        raster::GlContext* gl = raster::GlContext::Shared(&why);
        if (!gl) {
            std::fprintf(stderr, "raster_bench: %s\n", why.c_str());
            return 1;
        }
        clrt::Context ctx("cpu");
        const cl::Program program = render::BuildRenderProgram(ctx);
        std::printf("# %ux%u, GL: %s, CL: %s\n", width, height, gl->Renderer().c_str(),
                    ctx.info().name.c_str());
        std::printf("%-16s %8s %-16s %10s %10s %10s %12s %12s %10s\n", "scene", "prims", "method",
                    "pass_ms", "draw_ms", "read_ms", "frags/px", "tested/px", "id_mism");
        for (const std::string& name : scenes) {
            scene::Scene scene = name.rfind("spheres:", 0) == 0
                                     ? RandomSpheres(uint32_t(std::stoul(name.substr(8))))
                                     : scene::LoadScene(name);
            scene.camera.width = width;
            scene.camera.height = height;
            const std::string label = std::filesystem::path(name).filename().string();
            double kernelS = 0;
            const std::vector<RcHit> kernel = KernelHits(ctx, program, scene, kernelS);
            std::printf("%-16s %8u %-16s %10.1f %10s %10s %12s %12s %10s\n", label.c_str(),
                        scene.PrimitiveCount(), "cl-brute", kernelS * 1e3, "-", "-", "-", "-",
                        "-");
            const double pixels = double(width) * height;
            struct Method {
                const char* name;
                raster::Hull hull;
                uint32_t slabs;
            };
            const bool hasHulls = !scene.spheres.empty() || !scene.quadrics.empty();
            std::vector<Method> methods = {{"raster-auto", raster::Hull::Auto, 1}};
            if (hasHulls) {
                methods.push_back({"raster-sphere", raster::Hull::Sphere, 1});
                methods.push_back({"raster-box", raster::Hull::Box, 1});
                methods.push_back({"raster-billboard", raster::Hull::Billboard, 1});
            }
            methods.push_back({"raster-auto-4slab", raster::Hull::Auto, 4});
            methods.push_back({"raster-auto-16slab", raster::Hull::Auto, 16});
            for (const Method& m : methods) {
                raster::RasterOptions options;
                options.hull = m.hull;
                options.slabs = m.slabs;
                // Timing without counters: best of 3 after a warm-up frame (shader compile).
                raster::RasterPass pass(*gl, scene, options);
                const RcCamera cam = render::CameraBasis(scene.camera).ToDevice();
                pass.Render(cam);
                raster::RasterStats best;
                best.totalS = 1e30;
                std::vector<RcHit> hits;
                for (int rep = 0; rep < 3; ++rep) {
                    raster::RasterStats st;
                    hits = pass.Render(cam, &st);
                    if (st.totalS < best.totalS) best = st;
                }
                size_t mismatch = 0;
                for (size_t i = 0; i < hits.size(); ++i) mismatch += hits[i].prim != kernel[i].prim;
                options.countFragments = true;
                raster::RasterPass counting(*gl, scene, options);
                raster::RasterStats counted;
                counting.Render(cam, &counted);
                std::printf("%-16s %8u %-16s %10.1f %10.1f %10.1f %12.2f %12.2f %10zu\n",
                            label.c_str(), scene.PrimitiveCount(), m.name, best.totalS * 1e3,
                            best.drawS * 1e3, best.readbackS * 1e3,
                            double(counted.fragments) / pixels, double(counted.tested) / pixels,
                            mismatch);
                std::fflush(stdout);
            }
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "raster_bench: %s\n", e.what());
        return 1;
    }
    return 0;
}
