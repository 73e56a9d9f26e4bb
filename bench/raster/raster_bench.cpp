// Raster eye-ray pass against the OpenCL brute-force eye-ray query: time per hull type, depth
// complexity (fragments per pixel), id mismatches. Prints one line per (scene, method).
//
//   build/bench/raster_bench [WIDTH HEIGHT] [SCENE...]
// SCENE: a scene file, or spheres:N for N random spheres. Default: scenes/cornell.json,
// spheres:1000, spheres:10000, spheres:100000, scenes/bench/conference.obj.
// Environment as in the tests: POCL_MAX_PTHREAD_COUNT=2 is set unless given.
//
//   build/bench/raster_bench --experiments [--width W] [--height H] [--runs N]
//                            [--hull-counts N,N,...] [--depth-scene FILE]...
// The founding thesis's raster experiments (scripts/bench, charts 3 and 4), as CSV on stdout:
//   experiment,scene,prims,hull,slabs,depth_bits,x,pass_ms,draw_ms,frags_per_px,tested_per_px,
//   id_mismatch_fraction,reference_ms
// against the BVH eye-ray query's hits (reference_ms: its kernel time), best of N runs:
//   depth     each --depth-scene (default cornell.json) with RasterOptions.depthBits 16/24/32 and
//             depthScale = x times the derived scale (x > 1 loses the far hits)
//   hulls     x random spheres per --hull-counts, hull sphere/box/billboard
//   rotation  2000 ellipsoids 4:1:1, long axis rotated by x degrees about the view axis, hull
//             sphere/box/billboard (box and billboard follow the clip box, which grows)
//   layers    x screen-filling squares (2 triangles each) one behind the other, 1 and 4 slabs
// Exit status 3 when no OpenGL context can be made.
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "rayclass/clrt/context.h"
#include "rayclass/raster/raster_pass.h"
#include "rayclass/render/bvh_query.h"
#include "rayclass/render/brute_query.h"
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
    for (uint32_t i = 0; i < n; ++i)
        s.spheres.push_back({{pos(rng), pos(rng), pos(rng)}, rad(rng)});
    s.camera.position = {0, 0, 30};
    s.camera.lookAt = {0, 0, 0};
    s.camera.fovYDegrees = 45;
    return s;
}

std::vector<RcHit> KernelHits(clrt::Context& ctx, const cl::Program& program,
                              const scene::Scene& scene, double& seconds, bool bvh = false) {
    RcRenderParams params{};
    params.nTriangles = uint32_t(scene.triangles.size());
    params.nSpheres = uint32_t(scene.spheres.size());
    params.nQuadrics = uint32_t(scene.quadrics.size());
    const render::SceneBuffers buffers(ctx, scene, params);
    auto query = bvh ? render::MakeBvhQuery(ctx, program, buffers, scene)
                     : render::MakeBruteForceQuery(ctx, program, buffers);
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
    seconds = 0;
    for (const auto& [name, s] : timer.Seconds()) seconds += s;
    std::vector<RcHit> out(n);
    ctx.queue().enqueueReadBuffer(hits, CL_TRUE, 0, n * sizeof(RcHit), out.data());
    return out;
}

// Ellipsoids with semi-axes (4r, r, r), the long axis rotated by `degrees` about z (the view
// axis of the camera at +z), each clipped to its exact axis-aligned box.
scene::Scene RotatedEllipsoids(uint32_t n, float degrees) {
    scene::Scene s = RandomSpheres(n);
    const float c = std::cos(glm::radians(degrees)), sn = std::sin(glm::radians(degrees));
    const glm::mat3 rot(c, sn, 0, -sn, c, 0, 0, 0, 1);  // columns
    for (const scene::Sphere& sp : s.spheres) {
        const glm::vec3 semi(4 * sp.radius, sp.radius, sp.radius);
        const glm::mat3 inv2(glm::vec3(1 / (semi.x * semi.x), 0, 0),
                             glm::vec3(0, 1 / (semi.y * semi.y), 0),
                             glm::vec3(0, 0, 1 / (semi.z * semi.z)));
        const glm::mat3 a = rot * inv2 * glm::transpose(rot);  // (x-p)^T A (x-p) = 1
        const glm::vec3 p = sp.center, ap = a * p;
        scene::Quadric q;
        q.c = {a[0][0],     a[1][1],   a[2][2],   2 * a[1][0], 2 * a[2][0],
               2 * a[2][1], -2 * ap.x, -2 * ap.y, -2 * ap.z,   glm::dot(p, ap) - 1};
        glm::vec3 half;
        for (int i = 0; i < 3; ++i) {
            half[i] =
                glm::length(glm::vec3(rot[0][i] * semi.x, rot[1][i] * semi.y, rot[2][i] * semi.z));
        }
        q.boxMin = p - half;
        q.boxMax = p + half;
        s.quadrics.push_back(q);
    }
    s.spheres.clear();
    return s;
}

// `n` squares of side 40 facing the camera at z = 0, -0.5, -1, ... (front first).
scene::Scene Layers(uint32_t n) {
    scene::Scene s = RandomSpheres(0);
    for (uint32_t i = 0; i < n; ++i) {
        const float z = -0.5f * float(i);
        const glm::vec3 a(-20, -20, z), b(20, -20, z), c(20, 20, z), d(-20, 20, z);
        scene::Triangle t;
        t.p = {a, b, c};
        s.triangles.push_back(t);
        t.p = {a, c, d};
        s.triangles.push_back(t);
    }
    return s;
}

struct Measured {
    raster::RasterStats best, counted;
    size_t mismatchPixels = 0;
    double mismatch = 0;  // of the pixels
};

// Best of `runs` frames after a warm-up (shader compile), the counters from a separate counting
// pass, and the pixels whose id differs from `reference`.
Measured Measure(raster::GlContext& gl, const scene::Scene& scene, raster::RasterOptions options,
                 const std::vector<RcHit>& reference, int runs) {
    Measured m;
    const RcCamera cam = render::CameraBasis(scene.camera).ToDevice();
    raster::RasterPass pass(gl, scene, options);
    pass.Render(cam);
    m.best.totalS = 1e30;
    std::vector<RcHit> hits;
    for (int rep = 0; rep < runs; ++rep) {
        raster::RasterStats st;
        hits = pass.Render(cam, &st);
        if (st.totalS < m.best.totalS) m.best = st;
    }
    for (size_t i = 0; i < hits.size(); ++i) m.mismatchPixels += hits[i].prim != reference[i].prim;
    m.mismatch = double(m.mismatchPixels) / double(std::max<size_t>(1, hits.size()));
    options.countFragments = true;
    raster::RasterPass counting(gl, scene, options);
    counting.Render(cam, &m.counted);
    return m;
}

// The --experiments runs: one CSV row per scene and setting, against the BVH query's hits.
class Experiments {
  public:
    Experiments(raster::GlContext& gl, uint32_t width, uint32_t height, int runs)
        : gl_(gl),
          ctx_("cpu"),
          program_(render::BuildRenderProgram(ctx_)),
          width_(width),
          height_(height),
          runs_(runs) {}

    // Depth bits 16/24/32 and multiples of the derived depth scale on the scene of `file`.
    void Depth(const std::string& file) {
        scene::Scene scene = scene::LoadScene(file);
        const std::vector<RcHit> ref = Prepare(scene);
        raster::RasterPass probe(gl_, scene);
        probe.Render(render::CameraBasis(scene.camera).ToDevice());
        const double derived = probe.DepthScale();
        const std::string label = std::filesystem::path(file).stem().string();
        for (int bits : {16, 24, 32}) {
            for (double factor : {1.0 / 256, 1.0 / 16, 1.0, 2.0, 4.0}) {
                raster::RasterOptions options;
                options.depthBits = bits;
                options.depthScale = derived * factor;
                Row("depth", label, scene, options, factor, ref);
            }
        }
    }

    // One row per hull type for `scene`, against one reference query.
    void EveryHull(const char* experiment, const char* label, scene::Scene scene, double x) {
        const std::vector<RcHit> ref = Prepare(scene);
        for (raster::Hull hull :
             {raster::Hull::Sphere, raster::Hull::Box, raster::Hull::Billboard}) {
            raster::RasterOptions options;
            options.hull = hull;
            Row(experiment, label, scene, options, x, ref);
        }
    }

    // `n` layers of squares, without and with slabs.
    void Layered(uint32_t n) {
        scene::Scene scene = Layers(n);
        const std::vector<RcHit> ref = Prepare(scene);
        for (uint32_t slabs : {1u, 4u}) {
            raster::RasterOptions options;
            options.slabs = slabs;
            Row("layers", "squares", scene, options, n, ref);
        }
    }

  private:
    // The scene at the experiments' size, and its reference hits (their time in refS_).
    std::vector<RcHit> Prepare(scene::Scene& scene) {
        scene.camera.width = width_;
        scene.camera.height = height_;
        return KernelHits(ctx_, program_, scene, refS_, true);
    }

    void Row(const char* experiment, const std::string& label, const scene::Scene& scene,
             const raster::RasterOptions& options, double x, const std::vector<RcHit>& ref) {
        const double pixels = double(width_) * height_;
        const Measured m = Measure(gl_, scene, options, ref, runs_);
        std::printf("%s,%s,%u,%s,%u,%d,%g,%.4g,%.4g,%.4g,%.4g,%.6g,%.4g\n", experiment,
                    label.c_str(), scene.PrimitiveCount(), raster::HullName(options.hull),
                    options.slabs, options.depthBits, x, m.best.totalS * 1e3, m.best.drawS * 1e3,
                    double(m.counted.fragments) / pixels, double(m.counted.tested) / pixels,
                    m.mismatch, refS_ * 1e3);
        std::fflush(stdout);
    }

    raster::GlContext& gl_;
    clrt::Context ctx_;
    const cl::Program program_;
    uint32_t width_, height_;
    int runs_;
    double refS_ = 0;  // the last reference query's kernel time
};

int RunExperiments(int argc, char** argv) {
    uint32_t width = 400, height = 300;
    int runs = 3;
    std::vector<uint32_t> hullCounts{1000, 10000, 100000};
    std::vector<std::string> depthScenes;
    for (int i = 2; i + 1 < argc; i += 2) {
        const std::string a = argv[i], v = argv[i + 1];
        if (a == "--width")
            width = uint32_t(std::stoul(v));
        else if (a == "--height")
            height = uint32_t(std::stoul(v));
        else if (a == "--runs")
            runs = std::max(1, std::stoi(v));
        else if (a == "--depth-scene")
            depthScenes.push_back(v);
        else if (a == "--hull-counts") {
            hullCounts.clear();
            std::stringstream ss(v);
            for (std::string item; std::getline(ss, item, ',');)
                hullCounts.push_back(std::stoul(item));
        } else
            throw std::invalid_argument("unknown option " + a);
    }
    if (depthScenes.empty()) {
        depthScenes.push_back(
            (std::filesystem::path(RAYCLASS_BENCH_SOURCE_DIR) / "scenes/cornell.json").string());
    }
    std::string why;
    raster::GlContext* gl = raster::GlContext::Shared(&why);
    if (!gl) {
        std::fprintf(stderr, "raster_bench: no OpenGL context: %s\n", why.c_str());
        return 3;  // scripts/bench reports the experiments as skipped
    }
    Experiments e(*gl, width, height, runs);
    std::printf(
        "experiment,scene,prims,hull,slabs,depth_bits,x,pass_ms,draw_ms,frags_per_px,"
        "tested_per_px,id_mismatch_fraction,reference_ms\n");
    for (const std::string& file : depthScenes) e.Depth(file);
    for (uint32_t n : hullCounts) e.EveryHull("hulls", "spheres", RandomSpheres(n), n);
    for (float degrees : {0.0f, 15.0f, 30.0f, 45.0f, 60.0f, 75.0f, 90.0f}) {
        e.EveryHull("rotation", "ellipsoids", RotatedEllipsoids(2000, degrees), degrees);
    }
    for (uint32_t n : {1u, 2u, 4u, 8u, 16u, 32u, 64u}) e.Layered(n);
    return 0;
}

struct Method {
    const char* name;
    raster::Hull hull;
    uint32_t slabs;
};

// The raster methods worth comparing on `scene`: every hull only where it has spheres or
// quadrics.
std::vector<Method> MethodsFor(const scene::Scene& scene) {
    std::vector<Method> methods = {{"raster-auto", raster::Hull::Auto, 1}};
    if (!scene.spheres.empty() || !scene.quadrics.empty()) {
        methods.push_back({"raster-sphere", raster::Hull::Sphere, 1});
        methods.push_back({"raster-box", raster::Hull::Box, 1});
        methods.push_back({"raster-billboard", raster::Hull::Billboard, 1});
    }
    methods.push_back({"raster-auto-4slab", raster::Hull::Auto, 4});
    methods.push_back({"raster-auto-16slab", raster::Hull::Auto, 16});
    return methods;
}

// One line for the brute-force kernel on the scene `name`, then one per raster method.
void CompareMethods(raster::GlContext& gl, clrt::Context& ctx, const cl::Program& program,
                    const std::string& name, uint32_t width, uint32_t height) {
    scene::Scene scene = name.rfind("spheres:", 0) == 0
                             ? RandomSpheres(uint32_t(std::stoul(name.substr(8))))
                             : scene::LoadScene(name);
    scene.camera.width = width;
    scene.camera.height = height;
    const std::string label = std::filesystem::path(name).filename().string();
    double kernelS = 0;
    const std::vector<RcHit> kernel = KernelHits(ctx, program, scene, kernelS);
    std::printf("%-16s %8u %-16s %10.1f %10s %10s %12s %12s %10s\n", label.c_str(),
                scene.PrimitiveCount(), "cl-brute", kernelS * 1e3, "-", "-", "-", "-", "-");
    const double pixels = double(width) * height;
    for (const Method& method : MethodsFor(scene)) {
        raster::RasterOptions options;
        options.hull = method.hull;
        options.slabs = method.slabs;
        const Measured m = Measure(gl, scene, options, kernel, 3);
        std::printf("%-16s %8u %-16s %10.1f %10.1f %10.1f %12.2f %12.2f %10zu\n", label.c_str(),
                    scene.PrimitiveCount(), method.name, m.best.totalS * 1e3, m.best.drawS * 1e3,
                    m.best.readbackS * 1e3, double(m.counted.fragments) / pixels,
                    double(m.counted.tested) / pixels, m.mismatchPixels);
        std::fflush(stdout);
    }
}

std::vector<std::string> DefaultScenes() {
    const std::filesystem::path root = std::filesystem::path(RAYCLASS_BENCH_SOURCE_DIR);
    return {(root / "scenes/cornell.json").string(), "spheres:1000", "spheres:10000",
            "spheres:100000", (root / "scenes/bench/conference.obj").string()};
}

int Compare(int argc, char** argv) {
    uint32_t width = 400, height = 300;
    int a = 1;
    if (argc >= 3 && std::isdigit(static_cast<unsigned char>(argv[1][0]))) {
        width = uint32_t(std::atoi(argv[1]));
        height = uint32_t(std::atoi(argv[2]));
        a = 3;
    }
    std::vector<std::string> scenes(argv + a, argv + argc);
    if (scenes.empty()) scenes = DefaultScenes();
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
    for (const std::string& name : scenes) CompareMethods(*gl, ctx, program, name, width, height);
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    setenv("POCL_MAX_PTHREAD_COUNT", "2", 0);
    try {
        if (argc >= 2 && std::string(argv[1]) == "--experiments") {
            return RunExperiments(argc, argv);
        }
        return Compare(argc, argv);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "raster_bench: %s\n", e.what());
        return 1;
    }
}
