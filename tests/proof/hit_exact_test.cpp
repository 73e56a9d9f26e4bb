// Hit-exact at scale: renders of meshes of 10k to 331k triangles through every query path
// (--accel classify, bvh, auto, brute, kdtree, grid, cones), kernel style (vertex, fragment) and
// eye-ray path (the query, the raster pass), with the classification's defaults and with settings
// that force deep hierarchies, every generation checked: the primitive id and distance of every
// eye, reflection and refraction ray and the answer of every shadow ray equal brute force's
// (hit_oracle.h). Images are small so that the suite stays within its time; every ray of them is
// checked.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "clrt/device.h"
#include "hit_oracle.h"
#include "rayclass/classify/params.h"
#include "rayclass/clrt/context.h"
#include "rayclass/raster/gl.h"
#include "rayclass/raster/raster_pass.h"
#include "rayclass/render/cl_renderer.h"
#include "rayclass/scene/loader.h"

namespace rayclass::proof {
namespace {

using clrt::testing::TestContext;
using render::Accel;
using render::KernelStyle;

std::filesystem::path SceneDir() {
    const char* source = std::getenv("RAYCLASS_SOURCE_DIR");
    return std::filesystem::path(source ? source : ".") / "scenes";
}

scene::Material Mirror() {
    scene::Material m;
    m.kd = glm::vec3(0.3f);
    m.kr = glm::vec3(0.5f);
    return m;
}

scene::Material Glass() {
    scene::Material m;
    m.kd = glm::vec3(0.0f);
    m.kr = glm::vec3(0.1f);
    m.kt = glm::vec3(0.85f);
    m.ior = 1.5f;
    return m;
}

// Sibenik and Conference with their mirror walls, at a test resolution.
scene::Scene Bench(const std::string& file, uint32_t width, uint32_t height) {
    scene::Scene s = scene::LoadScene(SceneDir() / "bench" / file);
    s.camera.width = width;
    s.camera.height = height;
    return s;
}

// The bunny in glass (refraction rays through a closed mesh), every fourth triangle a mirror,
// framed and lit as a bare OBJ is.
scene::Scene GlassBunny(uint32_t width, uint32_t height) {
    scene::Scene s = scene::LoadScene(SceneDir() / "bench/bunny.obj");
    s.camera.width = width;
    s.camera.height = height;
    s.materials.push_back(Glass());
    s.materials.push_back(Mirror());
    for (size_t i = 0; i < s.triangles.size(); ++i) {
        s.triangles[i].material = uint32_t(s.materials.size() - (i % 4 == 0 ? 1 : 2));
    }
    return s;
}

// A random soup of 10,000 triangles of every size with mirror, glass and diffuse ones, 500 of
// them twice, 40 spheres and 4 clipped cylinders, seen from outside, two lights.
scene::Scene Soup(uint32_t width, uint32_t height) {
    std::mt19937 rng(40);
    std::uniform_real_distribution<float> pos(-10.0f, 10.0f), unit(-1.0f, 1.0f), size(0.05f, 2.0f);
    scene::Scene s;
    s.materials.push_back(Mirror());
    s.materials.push_back(Glass());
    for (int i = 0; i < 10000; ++i) {
        scene::Triangle t;
        const glm::vec3 c(pos(rng), pos(rng), pos(rng));
        const float r = size(rng);
        for (auto& p : t.p) p = c + r * glm::vec3(unit(rng), unit(rng), unit(rng));
        t.material = uint32_t(i % 3);
        s.triangles.push_back(t);
    }
    // Exact copies under higher ids: equal distances, where the lower id must win.
    for (int i = 0; i < 10000; i += 20) s.triangles.push_back(s.triangles[size_t(i)]);
    for (int i = 0; i < 40; ++i) {
        s.spheres.push_back({glm::vec3(pos(rng), pos(rng), pos(rng)), size(rng), uint32_t(i % 3)});
    }
    for (int i = 0; i < 4; ++i) {
        scene::Quadric q;
        const glm::vec3 c(pos(rng), pos(rng), pos(rng));
        const float r = 1.0f;
        q.c = {1, 0, 1, 0, 0, 0, -2 * c.x, 0, -2 * c.z, c.x * c.x + c.z * c.z - r * r};
        q.boxMin = c - glm::vec3(r, 3.0f, r);
        q.boxMax = c + glm::vec3(r, 3.0f, r);
        q.material = 1;
        s.quadrics.push_back(q);
    }
    s.lights.push_back({glm::vec3(0.0f, 14.0f, 14.0f), glm::vec3(300.0f)});
    s.lights.push_back({glm::vec3(3.0f, 1.0f, 2.0f), glm::vec3(20.0f)});
    s.camera.position = {4.0f, 6.0f, 30.0f};
    s.camera.lookAt = {0.0f, 0.0f, 0.0f};
    s.camera.width = width;
    s.camera.height = height;
    return s;
}

// Classification settings that split far below the defaults' leaves: every group of rays and
// every list splits while it can, across task and plan thresholds.
std::vector<classify::ParamSetting> Deep() {
    std::vector<classify::ParamSetting> settings;
    for (const auto& [name, value] :
         std::vector<std::pair<std::string, std::string>>{{"min-rays", "1"},
                                                          {"min-candidates", "1"},
                                                          {"min-origin-fraction", "0.00001"},
                                                          {"min-dir-fraction", "0.00001"},
                                                          {"task-rays", "256"},
                                                          {"plan-rays", "1024"},
                                                          {"threads", "2"}}) {
        settings.push_back(classify::ParseParam(name, value));
    }
    return settings;
}

struct Path {
    std::string name;
    Accel accel;
    KernelStyle kernel = KernelStyle::kAuto;
    bool deep = false;
    bool raster = false;
};

// Renders `s` through `path` with every answer checked; returns the tally.
Tally RenderChecked(const scene::Scene& s, const Path& path, uint32_t maxDepth,
                    uint32_t bruteEvery) {
    render::RenderOptions options;
    options.progress = false;
    options.maxDepth = maxDepth;
    options.accel = path.accel;
    options.kernel = path.kernel;
    if (path.deep) options.classifyParams = Deep();
    HitOracle oracle(s, bruteEvery);
    std::unique_ptr<raster::RasterEyeHits> raster;
    std::unique_ptr<CheckedEyeHits> eyeHits;
    if (path.raster) {
        std::string why;
        raster::GlContext* gl = raster::GlContext::Shared(&why);
        if (!gl) {
            ADD_FAILURE() << "no OpenGL context for the raster eye-ray path: " << why;
            return {};
        }
        raster = std::make_unique<raster::RasterEyeHits>(*gl, raster::RasterOptions{});
        eyeHits = std::make_unique<CheckedEyeHits>(*raster, oracle);
    }
    render::ClRenderer renderer(TestContext(), s, options, eyeHits.get(),
                                [&](std::unique_ptr<render::RayQuery> q) {
                                    return CheckedQuery(TestContext(), std::move(q), oracle);
                                });
    render::RenderStats stats;
    renderer.Render(stats);
    return oracle.tally();
}

// Every answer of every path's render exact; every `bruteEvery`-th ray also checked by brute
// force itself (as often as brute force over the scene's primitives is quick enough).
void ExpectExact(const scene::Scene& s, const std::vector<Path>& paths, uint32_t maxDepth,
                 uint32_t bruteEvery, const std::vector<std::string>& kinds) {
    for (const Path& path : paths) {
        SCOPED_TRACE(path.name);
        const Tally t = RenderChecked(s, path, maxDepth, bruteEvery);
        std::printf("[hit-exact] %s:%s\n", path.name.c_str(), t.Summary().c_str());
        for (const std::string& m : t.firstMismatches) ADD_FAILURE() << m;
        EXPECT_EQ(t.Mismatches(), 0u);
        for (const std::string& kind : kinds) {
            const auto it = t.byKind.find(kind);
            ASSERT_NE(it, t.byKind.end()) << "no " << kind << " rays";
            EXPECT_GT(it->second.hits, 0u) << kind;
            EXPECT_GT(it->second.bruteChecked, 0u) << kind;
        }
    }
}

TEST(HitExact, SibenikEveryGeneration) {
    const scene::Scene s = Bench("sibenik_mirror.json", 128, 96);
    ExpectExact(s,
                {{"classify fragment", Accel::kClassify, KernelStyle::kFragment},
                 {"classify vertex deep", Accel::kClassify, KernelStyle::kVertex, true},
                 {"auto", Accel::kAuto},
                 {"bvh", Accel::kBvh},
                 {"kdtree", Accel::kKdTree},
                 {"grid", Accel::kGrid},
                 {"classify raster eye rays", Accel::kClassify, KernelStyle::kAuto, false, true}},
                6, 151, {"eye", "reflection", "shadow"});
}

TEST(HitExact, ConferenceEveryGeneration) {
    const scene::Scene s = Bench("conference_mirror.json", 96, 72);
    ExpectExact(s,
                {{"classify vertex", Accel::kClassify, KernelStyle::kVertex},
                 {"classify fragment deep", Accel::kClassify, KernelStyle::kFragment, true},
                 {"bvh", Accel::kBvh}},
                3, 401, {"eye", "reflection", "shadow"});
}

TEST(HitExact, GlassBunnyEveryGeneration) {
    const scene::Scene s = GlassBunny(96, 72);
    ExpectExact(s,
                {{"classify fragment deep", Accel::kClassify, KernelStyle::kFragment, true},
                 {"classify vertex", Accel::kClassify, KernelStyle::kVertex},
                 {"auto raster eye rays", Accel::kAuto, KernelStyle::kAuto, false, true}},
                6, 53, {"eye", "reflection", "refraction", "shadow"});
}

TEST(HitExact, RandomSoupEveryGeneration) {
    const scene::Scene s = Soup(96, 72);
    ExpectExact(s,
                {{"classify vertex", Accel::kClassify, KernelStyle::kVertex},
                 {"classify fragment", Accel::kClassify, KernelStyle::kFragment},
                 {"classify vertex deep", Accel::kClassify, KernelStyle::kVertex, true},
                 {"classify fragment deep", Accel::kClassify, KernelStyle::kFragment, true},
                 {"auto deep", Accel::kAuto, KernelStyle::kAuto, true},
                 {"bvh", Accel::kBvh},
                 {"brute", Accel::kBrute},
                 {"kdtree", Accel::kKdTree},
                 {"grid", Accel::kGrid},
                 {"cones", Accel::kCones},
                 {"classify raster eye rays", Accel::kClassify, KernelStyle::kAuto, false, true}},
                6, 11, {"eye", "reflection", "refraction", "shadow"});
}

}  // namespace
}  // namespace rayclass::proof
