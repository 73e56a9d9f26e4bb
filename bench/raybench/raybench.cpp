// rayclass's side of scripts/bench: times each ray query (classified kernels per style, the BVH,
// the seed documents' structures: kdtree, grid, and cones and brute force on small scenes) on
// the ray sets of bench/common/raysets.h, one kind at a time.
//
//   raybench SCENE --camera NAME --light SPEC [--width W --height H] [--runs N] [--warmup N]
//            [--methods LIST] [--brute-max-prims N] [--save-rays FILE] [--cl-options S]
//            [--device D] [--seed S] [--kinds LIST] [--classify NAME=VALUE]... [--warm 0|1]
//   raybench --micro [--rays N] [--prims N] [--runs N]
//
// The eye rays' hits come from the BVH query (identical to brute force); the secondary sets are
// made from them on the host. Every measured run makes a fresh query (the classification's
// hierarchy is built lazily per render, so its construction is part of the host classification
// time) and answers the whole set. --warm 1 keeps one query per method and Resets it before each
// run: the hierarchy is still built from scratch every run, but in memory that earlier runs
// faulted in, as a render's later batches see it (a fresh query's scratch pages
// are faulted in inside the timed stage). CSV on stdout, one row per kind x method:
//   kind,method,rays,median_s,min_s,max_s,mrays_s,host_s,copy_s,kernel_s,shade_s,setup_s,
//   tests_per_ray,hits,hits_digest,uv_digest
// median_s: wall time of the query stage (host classification + copies + query kernels), the
// medians of host_s/copy_s/kernel_s split it; shade_s: separate shading kernels the classified
// styles launch (excluded from median_s; the vertex style's shading is fused into its query
// kernel and cannot be excluded); setup_s: query construction (BVH build and upload, the
// classification's presorted lists); mrays_s = rays / median_s; hits: rays that hit / are
// blocked; hits_digest: FNV-1a over every ray's answer in ray order (primitive id and the bits of
// t for a hit, the blocked byte for a shadow ray), equal across methods exactly when every
// ray's answer is; uv_digest: the same over the bits of each hit's u and v ("-" for shadow
// rays), which every method computes with the same operations, so it too is equal across them.
// The rays of the classified query are read back from the device
// inside the timed stage, as the renderer does, but for eye rays, which it classifies from their
// camera (Hierarchy::ClassifyPinhole) as the renderer does too. --classify sets a cost-function
// parameter of the classified methods as `rayclass render --classify` does (classify::SetParam),
// for sweeps. Method `auto` is the renderer's default query (`--accel auto --kernel auto`): each
// run is begun as a generation, where it picks classify/auto or bvh from what the runs before
// cost, so with --warm 1 its median is its steady state over like generations (with --warm 0
// every run is its first generation, classified). Its eye rays are classified, as a render's
// first generation always is, and so are its shadow rays, as a render's are until a nearest-hit
// generation has built the BVH. Its tests_per_ray are the last run's, whichever method answered
// it, while host_s is a median over runs: where auto changes method between runs (a noisy
// sample) the two can come from different methods.
//
// --micro: peak intersection tests per second for spheres, quadrics and triangles, N random rays
// against P primitives each (P a multiple of 16): the renderer's brute-force kernel (method
// brute-scalar: one ray per work-item, scalar loop) and the branch/select x scalar/vec16 variants
// of micro_kernels.h (methods scalar-branch, scalar-select, vec16-branch, vec16-select).
//   kind,method,rays,median_s,min_s,max_s,mrays_s,tests_per_s,hits
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <map>
#include <optional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "micro_kernels.h"
#include "rayclass/classify/params.h"
#include "rayclass/clrt/context.h"
#include "rayclass/render/auto_query.h"
#include "rayclass/render/brute_query.h"
#include "rayclass/render/bvh_query.h"
#include "rayclass/render/classified_query.h"
#include "rayclass/render/cones_query.h"
#include "rayclass/render/device_scene.h"
#include "rayclass/render/grid_query.h"
#include "rayclass/render/kdtree_query.h"
#include "rayclass/scene/loader.h"
#include "raysets.h"

using namespace rayclass;
using Clock = std::chrono::steady_clock;

namespace {

double Since(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

double Median(std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const size_t n = v.size();
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::vector<std::string> Split(const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string item;
    while (std::getline(ss, item, ',')) {
        if (!item.empty()) out.push_back(item);
    }
    return out;
}

template <typename T>
cl::Buffer Upload(clrt::Context& ctx, const std::vector<T>& v) {
    std::vector<T> one(1);
    return clrt::Check("clCreateBuffer", [&] {
        return cl::Buffer(ctx.context(), CL_MEM_READ_WRITE | CL_MEM_COPY_HOST_PTR,
                          std::max<size_t>(1, v.size()) * sizeof(T),
                          v.empty() ? one.data() : const_cast<T*>(v.data()));
    });
}

cl::Buffer Device(clrt::Context& ctx, size_t bytes) {
    return clrt::Check("clCreateBuffer", [&] {
        return cl::Buffer(ctx.context(), CL_MEM_READ_WRITE, std::max<size_t>(1, bytes));
    });
}

RcRenderParams ParamsFor(const scene::Scene& s) {
    RcRenderParams p{};
    p.nTriangles = uint32_t(s.triangles.size());
    p.nSpheres = uint32_t(s.spheres.size());
    p.nQuadrics = render::AnalyticRecords(s);
    p.nLights = uint32_t(s.lights.size());
    p.maxDepth = 6;
    p.minWeight = 1e-3f;
    p.ambient = {s.ambient.x, s.ambient.y, s.ambient.z, 0.0f};
    p.background = {s.background.x, s.background.y, s.background.z, 0.0f};
    return p;
}

struct Bench {
    clrt::Context& ctx;
    const scene::Scene& scene;
    cl::Program program;
    render::SceneBuffers buffers;
    classify::Params params;

    Bench(clrt::Context& c, const scene::Scene& s, const std::string& clOptions)
        : ctx(c),
          scene(s),
          program(render::BuildRenderProgram(c, clOptions)),
          buffers(c, s, ParamsFor(s)),
          params(classify::Params::ForScene(s)) {}

    std::unique_ptr<render::RayQuery> Make(const std::string& method) {
        if (method == "brute") return render::MakeBruteForceQuery(ctx, program, buffers);
        if (method == "bvh") return render::MakeBvhQuery(ctx, program, buffers, scene);
        if (method == "kdtree") return render::MakeKdTreeQuery(ctx, program, buffers, scene);
        if (method == "grid") return render::MakeGridQuery(ctx, program, buffers, scene);
        if (method == "cones") return render::MakeConesQuery(ctx, program, buffers, scene);
        if (method == "auto") {
            return render::MakeAutoQuery(
                ctx,
                render::MakeClassifiedQuery(ctx, program, buffers, scene, params,
                                            render::KernelStyle::kAuto),
                [this] { return render::MakeBvhQuery(ctx, program, buffers, scene); });
        }
        const auto style = method.starts_with("classify/")
                               ? render::FindChoice(render::kKernelStyles, method.substr(9))
                               : std::nullopt;
        if (style) return render::MakeClassifiedQuery(ctx, program, buffers, scene, params, *style);
        throw std::invalid_argument("unknown method '" + method + "'");
    }
};

RcRay ToRc(const bench::BenchRay& r) {
    RcRay o{};
    o.origin = {r.origin.x, r.origin.y, r.origin.z, r.tMin};
    o.direction = {r.direction.x, r.direction.y, r.direction.z, r.tMax};
    return o;
}

RcRayInfo InfoOf(uint32_t kind) {
    RcRayInfo o{};
    o.weight = {1.0f, 1.0f, 1.0f, 0.0f};
    o.depth = kind == RC_RAY_EYE ? 0 : 1;
    o.kind = kind;
    return o;
}

// Component k of primitive i at [k * n + i]: sphere centre, radius; triangle v0, e1, e2; quadric
// coefficients, box min, box max (the layout micro_kernels.h reads).
std::vector<float> MicroSoa(const scene::Scene& s, uint32_t n) {
    std::vector<float> soa;
    auto put = [&](uint32_t k, uint32_t i, float v) {
        if (soa.size() < size_t(k + 1) * n) soa.resize(size_t(k + 1) * n, 0.0f);
        soa[size_t(k) * n + i] = v;
    };
    for (uint32_t i = 0; i < s.spheres.size(); ++i) {
        const auto& sp = s.spheres[i];
        for (int k = 0; k < 3; ++k) put(k, i, sp.center[k]);
        put(3, i, sp.radius);
    }
    for (uint32_t i = 0; i < s.triangles.size(); ++i) {
        const auto& p = s.triangles[i].p;
        for (int k = 0; k < 3; ++k) {
            put(k, i, p[0][k]);
            put(3 + k, i, p[1][k] - p[0][k]);
            put(6 + k, i, p[2][k] - p[0][k]);
        }
    }
    for (uint32_t i = 0; i < s.quadrics.size(); ++i) {
        const auto& q = s.quadrics[i];
        for (int k = 0; k < 10; ++k) put(k, i, q.c[k]);
        for (int k = 0; k < 3; ++k) {
            put(10 + k, i, q.boxMin[k]);
            put(13 + k, i, q.boxMax[k]);
        }
    }
    return soa;
}

// Applies the OPTION VALUE pairs of argv[2...] through `options`; an unknown option is an
// error that names it (and its value, when `namesValue`).
void ParsePairs(int argc, char** argv,
                const std::map<std::string, std::function<void(const std::string&)>>& options,
                bool namesValue) {
    for (int i = 2; i + 1 < argc; i += 2) {
        const std::string o = argv[i], v = argv[i + 1];
        const auto option = options.find(o);
        if (option == options.end()) {
            throw std::invalid_argument("unknown option " + o + (namesValue ? " " + v : ""));
        }
        option->second(v);
    }
}

// The micro benchmark's random numbers: one stream for a kind's primitives and then its rays.
struct MicroRandom {
    std::mt19937 rng{3};
    std::uniform_real_distribution<float> pos{-1.0f, 1.0f}, off{-0.1f, 0.1f}, rad{0.02f, 0.08f};
    // Parenthesised, as the benchmark always drew them: the order in which a call's arguments
    // are evaluated is the compiler's, and braces would fix another.
    glm::vec3 Point() { return glm::vec3(pos(rng), pos(rng), pos(rng)); }
};

// `n` primitives of `kind` scattered in [-1,1]^3, small enough that most rays miss most of them.
scene::Scene MicroScene(const std::string& kind, uint32_t n, MicroRandom& random) {
    scene::Scene s;
    s.lights.push_back({glm::vec3(0, 5, 0), glm::vec3(1)});
    for (uint32_t p = 0; p < n; ++p) {
        const glm::vec3 c = random.Point();
        if (kind == "sphere") {
            s.spheres.push_back({c, random.rad(random.rng), 0, 0});
        } else if (kind == "quadric") {
            scene::Quadric q;  // an ellipsoid x^2/a + y^2/b + z^2/c about c, clipped
            const float r = random.rad(random.rng);
            q.c = {1, 1,        1,        0,        0,
                   0, -2 * c.x, -2 * c.y, -2 * c.z, c.x * c.x + c.y * c.y + c.z * c.z - r * r};
            q.boxMin = c - glm::vec3(r);
            q.boxMax = c + glm::vec3(r);
            s.quadrics.push_back(q);
        } else {
            auto offset = [&random] {
                return glm::vec3(random.off(random.rng), random.off(random.rng),
                                 random.off(random.rng));
            };
            scene::Triangle t;
            const glm::vec3 b = c + offset();
            t.p = {c, b, c + offset()};
            s.triangles.push_back(t);
        }
    }
    return s;
}

// `n` rays from z = -4 towards random points of the box.
std::vector<RcRay> MicroRays(uint32_t n, MicroRandom& random) {
    std::vector<RcRay> rays(n);
    for (uint32_t i = 0; i < n; ++i) {
        bench::BenchRay r;
        r.origin = glm::vec3(0, 0, -4);
        r.direction = glm::normalize(random.Point() - r.origin);
        r.tMax = INFINITY;
        rays[i] = ToRc(r);
    }
    return rays;
}

struct MicroCase {
    std::string kind;
    uint32_t nRays, nPrims;
    int runs;

    void Report(std::string method, std::vector<double> times, uint64_t hits) const {
        const double med = Median(times);
        std::sort(times.begin(), times.end());
        std::replace(method.begin(), method.end(), '_', '-');
        std::printf("%s,%s,%u,%.6g,%.6g,%.6g,%.4g,%.4g,%llu\n", kind.c_str(), method.c_str(), nRays,
                    med, times.front(), times.back(), nRays / med * 1e-6,
                    double(nRays) * nPrims / med, (unsigned long long)hits);
        std::fflush(stdout);
    }
};

// The renderer's brute-force kernel on `rays` (run 0 is the warm-up).
void MicroBrute(clrt::Context& ctx, const scene::Scene& s, const std::vector<RcRay>& rays,
                const MicroCase& c) {
    Bench b(ctx, s, "");
    const cl::Buffer raysBuf = Upload(ctx, rays);
    const cl::Buffer hits = Device(ctx, c.nRays * sizeof(RcHit));
    auto q = b.Make("brute");
    std::vector<double> times;
    for (int r = 0; r <= c.runs; ++r) {
        render::KernelTimer timer;
        q->Intersect(raysBuf, c.nRays, nullptr, hits, {}, timer);
        if (r > 0) times.push_back(timer.Seconds().begin()->second);
    }
    std::vector<RcHit> h(c.nRays);
    ctx.queue().enqueueReadBuffer(hits, CL_TRUE, 0, c.nRays * sizeof(RcHit), h.data());
    c.Report("brute-scalar", times,
             std::count_if(h.begin(), h.end(), [](const RcHit& x) { return x.prim != RC_NO_HIT; }));
}

// The same primitives in SoA for the variants of micro_kernels.h (run 0 is the warm-up).
void MicroVariants(clrt::Context& ctx, const cl::Program& micro, const scene::Scene& s,
                   const std::vector<RcRay>& rays, const MicroCase& c) {
    std::vector<rc_float4> orig(c.nRays), dir(c.nRays);
    for (uint32_t i = 0; i < c.nRays; ++i) {
        orig[i] = rays[i].origin;
        dir[i] = rays[i].direction;
    }
    const cl::Buffer primsBuf = Upload(ctx, MicroSoa(s, c.nPrims)), origBuf = Upload(ctx, orig),
                     dirBuf = Upload(ctx, dir);
    const cl::Buffer outT = Device(ctx, c.nRays * sizeof(float)),
                     outId = Device(ctx, c.nRays * sizeof(uint32_t));
    for (const char* variant : {"scalar_branch", "scalar_select", "vec16_branch", "vec16_select"}) {
        cl::Kernel k(micro, (c.kind + "_" + variant).c_str());
        render::SetArgs(k, origBuf, dirBuf, c.nRays, primsBuf, c.nPrims, outT, outId);
        std::vector<double> times;
        for (int r = 0; r <= c.runs; ++r) {
            const auto t0 = Clock::now();
            ctx.queue().enqueueNDRangeKernel(
                k, cl::NullRange, cl::NDRange(clrt::RoundUp(c.nRays, 64)), cl::NDRange(64));
            ctx.queue().finish();
            if (r > 0) times.push_back(Since(t0));
        }
        std::vector<uint32_t> ids(c.nRays);
        ctx.queue().enqueueReadBuffer(outId, CL_TRUE, 0, c.nRays * sizeof(uint32_t), ids.data());
        c.Report(variant, times,
                 std::count_if(ids.begin(), ids.end(), [](uint32_t x) { return x != ~0u; }));
    }
}

cl::Program BuildMicro(const clrt::Context& ctx) {
    cl::Program micro(ctx.context(), bench::kMicroSource);
    try {
        micro.build("-cl-std=CL1.2");
    } catch (const cl::Error&) {
        throw std::runtime_error("micro kernels: " +
                                 micro.getBuildInfo<CL_PROGRAM_BUILD_LOG>(ctx.device()));
    }
    return micro;
}

int Micro(int argc, char** argv) {
    MicroCase c{"", 1u << 18, 256, 5};
    std::string device = "auto";
    ParsePairs(argc, argv,
               {{"--rays", [&c](const std::string& v) { c.nRays = uint32_t(std::stoul(v)); }},
                {"--prims", [&c](const std::string& v) { c.nPrims = uint32_t(std::stoul(v)); }},
                {"--runs", [&c](const std::string& v) { c.runs = std::max(1, std::stoi(v)); }},
                {"--device", [&device](const std::string& v) { device = v; }}},
               /*namesValue=*/false);
    if (c.nPrims % 16 != 0) throw std::invalid_argument("--prims must be a multiple of 16");
    clrt::Context ctx(device);
    const cl::Program micro = BuildMicro(ctx);
    std::printf("kind,method,rays,median_s,min_s,max_s,mrays_s,tests_per_s,hits\n");
    for (const char* kind : {"sphere", "quadric", "triangle"}) {
        c.kind = kind;
        MicroRandom random;
        const scene::Scene s = MicroScene(kind, c.nPrims, random);
        const std::vector<RcRay> rays = MicroRays(c.nRays, random);
        MicroBrute(ctx, s, rays, c);
        MicroVariants(ctx, micro, s, rays, c);
    }
    return 0;
}

struct Args {
    std::string scene, camera = "scene", light = "scene", saveRays, clOptions, device = "auto";
    uint32_t width = 1024, height = 768, seed = 1, bruteMaxPrims = 5000;
    int runs = 5, warmup = 1;
    bool warm = false;
    std::vector<std::string> kinds{std::begin(bench::kKinds), std::end(bench::kKinds)};
    std::vector<std::pair<std::string, std::string>> classifyParams;
    std::vector<std::string> methods{"classify/scalar",
                                     "classify/vertex",
                                     "classify/fragment",
                                     "classify/auto",
                                     "bvh",
                                     "kdtree",
                                     "grid",
                                     "cones",
                                     "brute"};
};

Args ParseArgs(int argc, char** argv) {
    Args a;
    a.scene = argv[1];
    auto count = [](uint32_t& field) {
        return [&field](const std::string& v) { field = uint32_t(std::stoul(v)); };
    };
    auto text = [](std::string& field) { return [&field](const std::string& v) { field = v; }; };
    ParsePairs(argc, argv,
               {{"--camera", text(a.camera)},
                {"--light", text(a.light)},
                {"--width", count(a.width)},
                {"--height", count(a.height)},
                {"--runs", [&a](const std::string& v) { a.runs = std::max(1, std::stoi(v)); }},
                {"--warmup", [&a](const std::string& v) { a.warmup = std::max(0, std::stoi(v)); }},
                {"--methods", [&a](const std::string& v) { a.methods = Split(v); }},
                {"--kinds", [&a](const std::string& v) { a.kinds = Split(v); }},
                {"--brute-max-prims", count(a.bruteMaxPrims)},
                {"--save-rays", text(a.saveRays)},
                {"--cl-options", text(a.clOptions)},
                {"--device", text(a.device)},
                {"--seed", count(a.seed)},
                {"--warm", [&a](const std::string& v) { a.warm = v == "1"; }},
                {"--classify",
                 [&a](const std::string& v) {
                     if (v.find('=') == std::string::npos) {
                         throw std::invalid_argument("unknown option --classify " + v);
                     }
                     a.classifyParams.emplace_back(v.substr(0, v.find('=')),
                                                   v.substr(v.find('=') + 1));
                 }}},
               /*namesValue=*/true);
    return a;
}

// The eye rays' hits, by the BVH query (identical to brute force).
std::vector<bench::BenchHit> EyeHits(Bench& b, const std::vector<bench::BenchRay>& eye) {
    std::vector<RcRay> eyeRc(eye.size());
    for (size_t i = 0; i < eye.size(); ++i) eyeRc[i] = ToRc(eye[i]);
    const cl::Buffer raysBuf = Upload(b.ctx, eyeRc);
    const cl::Buffer hits = Device(b.ctx, eye.size() * sizeof(RcHit));
    render::KernelTimer timer;
    b.Make("bvh")->Intersect(raysBuf, uint32_t(eye.size()), nullptr, hits, {}, timer);
    std::vector<RcHit> h(eye.size());
    clrt::Check("clEnqueueReadBuffer", [&] {
        b.ctx.queue().enqueueReadBuffer(hits, CL_TRUE, 0, h.size() * sizeof(RcHit), h.data());
    });
    std::vector<bench::BenchHit> out(eye.size());
    for (size_t i = 0; i < h.size(); ++i) out[i] = {h[i].t, h[i].prim, h[i].u, h[i].v};
    return out;
}

// One kind's rays on the device, and what its queries write.
struct KindRays {
    int kind = 0;
    bool shadow = false;
    uint32_t n = 0;
    std::vector<RcRay> rays;
    render::ShadeBuffers shade;
    cl::Buffer raysBuf, out;
    const RcCamera* camera = nullptr;  // eye rays come with their camera, as in the renderer
};

KindRays UploadKind(clrt::Context& ctx, const std::vector<bench::BenchRay>& set, int k,
                    uint32_t nLights, const RcCamera& eyeCamera) {
    KindRays kr;
    kr.kind = k;
    kr.shadow = bench::IsShadowKind(k);
    kr.n = uint32_t(set.size());
    kr.shade = render::MakeShadeBuffers(ctx, kr.n, nLights);
    for (const auto& r : set) kr.rays.push_back(ToRc(r));
    kr.raysBuf = Upload(ctx, kr.rays);
    if (k == 0) kr.camera = &eyeCamera;
    // Eye rays have no infos, as in the renderer (rc_types.h).
    if (!kr.shadow && k != 0) {
        const uint32_t kind = k == 3 ? RC_RAY_REFRACTION : RC_RAY_REFLECTION;
        kr.shade.rayInfo = Upload(ctx, std::vector<RcRayInfo>(kr.n, InfoOf(kind)));
    }
    kr.out = Device(ctx, size_t(kr.n) * (kr.shadow ? 1 : sizeof(RcHit)));
    return kr;
}

// The query stage on the kind's rays: the primitive tests done.
uint64_t Query(render::RayQuery& q, const KindRays& kr, cl::CommandQueue& queue,
               render::KernelTimer& timer) {
    if (kr.shadow) return q.Occluded(kr.raysBuf, kr.rays, kr.out, timer);
    render::RaySource source;
    source.camera = kr.camera;
    std::unique_ptr<render::PreparedBatch> prepared = q.Prepare(kr.raysBuf, kr.n, queue, source);
    const uint64_t tests =
        q.Intersect(kr.raysBuf, kr.n, prepared.get(), kr.out, kr.shade, timer).tests;
    q.Recycle(std::move(prepared));
    return tests;
}

// Seconds per measured run: wall (without shading), host, copy, kernel, shading and setup.
struct Timings {
    std::vector<double> wall, host, copy, kern, shade, setup;
    uint64_t tests = 0;
};

Timings Measure(Bench& b, const Args& a, const std::string& method, const KindRays& kr) {
    Timings t;
    std::unique_ptr<render::RayQuery> q;
    double setupS = 0;
    for (int r = 0; r < a.warmup + a.runs; ++r) {
        const auto ts = Clock::now();
        if (!a.warm || !q) {
            q = b.Make(method);
            setupS = Since(ts);
        } else {
            q->Reset();
        }
        render::KernelTimer timer;
        const double host0 = q->Stats().hostSeconds;
        const auto tq = Clock::now();
        // Each run of secondary rays is a generation, begun as the renderer begins one: auto
        // picks its method there, from the runs before. Eye rays are a render's first
        // generation, which auto always classifies.
        if (!kr.shadow && !kr.camera) q->BeginGeneration(uint32_t(r), kr.raysBuf, kr.n, timer);
        t.tests = Query(*q, kr, b.ctx.queue(), timer);
        b.ctx.queue().finish();
        const double w = Since(tq);
        double ks = 0, ss = 0;
        for (const auto& [name, s] : timer.Seconds()) {
            (name == "rc_shade16_ids" ? ss : ks) += s;
        }
        const double hs = q->Stats().hostSeconds - host0;
        if (r < a.warmup) continue;
        t.wall.push_back(w - ss);
        t.host.push_back(hs);
        t.kern.push_back(ks);
        t.shade.push_back(ss);
        t.copy.push_back(std::max(0.0, w - ss - hs - ks));
        t.setup.push_back(setupS);
    }
    return t;
}

// Rays that hit or are blocked, and the digest of every ray's answer (outside the timing): both
// equal across methods.
struct HitSummary {
    static constexpr uint64_t kBasis = 14695981039346656037ull;  // FNV-1a offset basis
    uint64_t hits = 0;
    uint64_t digest = kBasis;
    std::optional<uint64_t> uvDigest;  // none for shadow rays

    static void Add(uint64_t& to, const void* data, size_t size) {
        for (size_t i = 0; i < size; ++i) {
            to = (to ^ static_cast<const uint8_t*>(data)[i]) * 1099511628211ull;
        }
    }
    void Add(const void* data, size_t size) { Add(digest, data, size); }
};

HitSummary SummarizeHits(clrt::Context& ctx, const KindRays& kr) {
    HitSummary s;
    if (kr.shadow) {
        std::vector<uint8_t> blocked(kr.n);
        clrt::Check("clEnqueueReadBuffer", [&] {
            ctx.queue().enqueueReadBuffer(kr.out, CL_TRUE, 0, kr.n, blocked.data());
        });
        for (uint8_t x : blocked) {
            const uint8_t b = x != 0;
            s.hits += b;
            s.Add(&b, 1);
        }
        return s;
    }
    s.uvDigest = HitSummary::kBasis;
    std::vector<RcHit> h(kr.n);
    clrt::Check("clEnqueueReadBuffer", [&] {
        ctx.queue().enqueueReadBuffer(kr.out, CL_TRUE, 0, kr.n * sizeof(RcHit), h.data());
    });
    for (const auto& x : h) {
        s.Add(&x.prim, sizeof(x.prim));
        if (x.prim == RC_NO_HIT) continue;
        ++s.hits;
        s.Add(&x.t, sizeof(x.t));
        HitSummary::Add(*s.uvDigest, &x.u, sizeof(x.u));
        HitSummary::Add(*s.uvDigest, &x.v, sizeof(x.v));
    }
    return s;
}

std::string UvDigestText(const HitSummary& hits) {
    if (!hits.uvDigest) return "-";
    char text[17];
    std::snprintf(text, sizeof text, "%016llx", (unsigned long long)*hits.uvDigest);
    return text;
}

void PrintRow(const KindRays& kr, const std::string& method, const Timings& t,
              const HitSummary& hits) {
    const double med = Median(t.wall);
    std::printf("%s,%s,%u,%.6g,%.6g,%.6g,%.4g,%.6g,%.6g,%.6g,%.6g,%.6g,%.4g,%llu,%016llx,%s\n",
                bench::kKinds[kr.kind], method.c_str(), kr.n, med,
                *std::min_element(t.wall.begin(), t.wall.end()),
                *std::max_element(t.wall.begin(), t.wall.end()), kr.n / med * 1e-6, Median(t.host),
                Median(t.copy), Median(t.kern), Median(t.shade), Median(t.setup),
                double(t.tests) / kr.n, (unsigned long long)hits.hits,
                (unsigned long long)hits.digest, UvDigestText(hits).c_str());
    std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) try {
    if (argc >= 2 && std::string(argv[1]) == "--micro") return Micro(argc, argv);
    if (argc < 2 || argv[1][0] == '-') {
        std::fprintf(stderr,
                     "usage: raybench SCENE --camera NAME --light SPEC [options] | "
                     "raybench --micro [options] (see bench/raybench/raybench.cpp)\n");
        return 2;
    }
    const Args a = ParseArgs(argc, argv);
    auto t0 = Clock::now();
    const scene::Scene sc = scene::LoadScene(a.scene);
    const double loadS = Since(t0);
    clrt::Context ctx(a.device);
    t0 = Clock::now();
    Bench b(ctx, sc, a.clOptions);
    for (const auto& [name, value] : a.classifyParams) classify::SetParam(b.params, name, value);
    const double buildS = Since(t0);

    // Eye rays and their hits, then the secondary sets.
    const scene::Camera cam = bench::NamedCamera(sc, a.camera, a.width, a.height);
    const glm::vec3 lightPos = bench::NamedLight(sc, a.light);
    const std::vector<bench::BenchRay> eye = bench::EyeRays(cam);
    const RcCamera eyeCamera = render::CameraBasis(cam).ToDevice();
    const bench::RaySets sets = bench::MakeRaySets(sc, eye, EyeHits(b, eye), lightPos, a.seed, a.width);
    if (!a.saveRays.empty()) bench::SaveRaySets(a.saveRays, sets);
    std::fprintf(stderr,
                 "raybench: %s, %u primitives, camera %s, load %.3f s, program build %.3f s; "
                 "rays eye %zu shadow %zu reflection %zu refraction %zu diffuse %zu\n",
                 a.scene.c_str(), sc.PrimitiveCount(), a.camera.c_str(), loadS, buildS,
                 sets.sets[0].size(), sets.sets[1].size(), sets.sets[2].size(), sets.sets[3].size(),
                 sets.sets[4].size());

    std::printf(
        "kind,method,rays,median_s,min_s,max_s,mrays_s,host_s,copy_s,kernel_s,shade_s,"
        "setup_s,tests_per_ray,hits,hits_digest,uv_digest\n");
    const uint32_t nLights = std::max<uint32_t>(1, uint32_t(sc.lights.size()));
    for (int k = 0; k < bench::kNumKinds; ++k) {
        const auto& set = sets.sets[k];
        if (set.empty() ||
            std::find(a.kinds.begin(), a.kinds.end(), bench::kKinds[k]) == a.kinds.end())
            continue;
        const KindRays kr = UploadKind(ctx, set, k, nLights, eyeCamera);
        for (const std::string& method : a.methods) {
            // The hierarchical ray engine costs brute force's on rays its cones cannot bound.
            if ((method == "brute" || method == "cones") && sc.PrimitiveCount() > a.bruteMaxPrims)
                continue;
            const Timings t = Measure(b, a, method, kr);
            PrintRow(kr, method, t, SummarizeHits(ctx, kr));
        }
    }
    return 0;
} catch (const std::exception& e) {
    std::fprintf(stderr, "raybench: %s\n", e.what());
    return 1;
}
