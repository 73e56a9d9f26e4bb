// What the accelerations' suites share: the OpenCL context, the query a method name makes, and
// the rays of every kind scripts/bench measures, sampled from a scene's camera.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "rayclass/clrt/context.h"
#include "rayclass/render/brute_query.h"
#include "rayclass/render/cones_query.h"
#include "rayclass/render/device_scene.h"
#include "rayclass/render/grid_query.h"
#include "rayclass/render/kdtree_query.h"
#include "rayclass/render/launch.h"
#include "rayclass/render/ray_query.h"
#include "raysets.h"
#include "render/query_io.h"
#include "test_device.h"

namespace rayclass::accel {

inline clrt::Context& Ctx() {
    static clrt::Context ctx(TestDeviceSpec());
    return ctx;
}

inline const cl::Program& Program() {
    static const cl::Program program = render::BuildRenderProgram(Ctx());
    return program;
}

inline std::filesystem::path SourceDir() {
    const char* dir = std::getenv("RAYCLASS_SOURCE_DIR");
    return dir ? dir : ".";
}

inline RcRenderParams ParamsOf(const scene::Scene& s) {
    RcRenderParams p{};
    p.nTriangles = uint32_t(s.triangles.size());
    p.nSpheres = uint32_t(s.spheres.size());
    p.nQuadrics = render::AnalyticRecords(s);  // quadrics, then patch boxes
    return p;
}

// A scene with its device buffers and the brute-force query, the oracle.
struct Loaded {
    scene::Scene scene;
    render::SceneBuffers buffers{Ctx(), scene, ParamsOf(scene)};
    std::unique_ptr<render::RayQuery> brute =
        render::MakeBruteForceQuery(Ctx(), Program(), buffers);

    explicit Loaded(scene::Scene s) : scene(std::move(s)) {}

    std::unique_ptr<render::RayQuery> Make(const std::string& method) const {
        if (method == "kdtree") return render::MakeKdTreeQuery(Ctx(), Program(), buffers, scene);
        if (method == "grid") return render::MakeGridQuery(Ctx(), Program(), buffers, scene);
        if (method == "cones") return render::MakeConesQuery(Ctx(), Program(), buffers, scene);
        throw std::invalid_argument("unknown method " + method);
    }
};

inline RcRay ToRc(const bench::BenchRay& r) {
    return {{r.origin.x, r.origin.y, r.origin.z, r.tMin},
            {r.direction.x, r.direction.y, r.direction.z, r.tMax}};
}

inline std::vector<RcRay> ToRc(const std::vector<bench::BenchRay>& rays) {
    std::vector<RcRay> out;
    out.reserve(rays.size());
    for (const auto& r : rays) out.push_back(ToRc(r));
    return out;
}

// Eye rays of the scene's camera at width x height, then the shadow, reflection, refraction and
// diffuse rays of scripts/bench from their hits (found by brute force).
inline bench::RaySets SampledRaySets(const Loaded& l, uint32_t width, uint32_t height) {
    scene::Camera cam = bench::NamedCamera(l.scene, "scene", width, height);
    const std::vector<bench::BenchRay> eye = bench::EyeRays(cam);
    const std::vector<RcHit> hits = render::NearestHits(Ctx(), *l.brute, ToRc(eye));
    std::vector<bench::BenchHit> benchHits;
    for (const RcHit& h : hits) benchHits.push_back({h.t, h.prim, h.u, h.v});
    const glm::vec3 light = l.scene.lights.empty() ? cam.position : l.scene.lights[0].position;
    return bench::MakeRaySets(l.scene, eye, benchHits, light, 7, width);
}

}  // namespace rayclass::accel
