// rc_shade16_ids (cl/shade16.cl), given no id list, shades 16 rays a work-item in float16 lanes
// and must write what the scalar rc_shade (cl/shade.cl) writes, byte for byte: radiance, normals,
// shadow slots, secondary rays and their flags. The hits are made up rather than found, so every
// kind of primitive (the teapot's patch boxes and sphere, triangles with and without vertex
// normals, degenerate and tiny triangles whose squared lengths leave the normal float range,
// quadrics) meets every kind of material (matte, specular, mirror, glass with and without Fresnel,
// emissive), with misses, weights below the spawn threshold, depths at the limit and a batch that
// is not a multiple of 16 rays.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <vector>

#include "clrt/device.h"
#include "rayclass/clrt/context.h"
#include "rayclass/render/buffers.h"
#include "rayclass/render/device_scene.h"
#include "rayclass/render/launch.h"
#include "rayclass/scene/loader.h"
#include "scene/test_files.h"

namespace rayclass::render {
namespace {

using clrt::testing::TestContext;
using scene::testing::ScenesDir;

// The teapot scene (patch boxes, a sphere) with triangles, quadrics and more materials added.
scene::Scene MixedScene() {
    scene::Scene s = scene::LoadScene(ScenesDir() / "teapot.json");
    scene::Material specular, mirror, glass, tirGlass, lamp;
    specular.ks = glm::vec3(0.5f);
    specular.shininess = 20.0f;
    mirror.kd = glm::vec3(0.2f);
    mirror.kr = glm::vec3(0.7f);
    glass.kd = glm::vec3(0.0f);
    glass.kt = glm::vec3(0.9f);
    glass.fresnel = true;
    tirGlass.kt = glm::vec3(0.8f);
    tirGlass.kr = glm::vec3(0.1f);
    tirGlass.ior = 2.4f;
    lamp.emission = glm::vec3(2.0f, 1.0f, 0.5f);
    for (const scene::Material& m : {specular, mirror, glass, tirGlass, lamp}) {
        s.materials.push_back(m);
    }
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> pos(-3.0f, 3.0f), off(-0.5f, 0.5f);
    for (int i = 0; i < 64; ++i) {
        scene::Triangle t;
        const glm::vec3 a(pos(rng), pos(rng), pos(rng));
        t.p = {a, a + glm::vec3(off(rng), off(rng), off(rng)),
               a + glm::vec3(off(rng), off(rng), off(rng))};
        if (i % 8 == 1) t.p[2] = t.p[1];  // no area: the normal falls back
        if (i % 8 == 2) t.p = {a, a + 1e-21f, a + glm::vec3(0, 1e-21f, 3e-21f)};    // subnormal
        if (i % 8 == 3) t.p = {a * 1e12f, a * -1e12f, glm::vec3(1e12f, 0, 1e12f)};  // overflow
        if (i % 2 == 0) {
            t.hasNormals = true;
            for (glm::vec3& n : t.n) n = glm::normalize(glm::vec3(off(rng), off(rng), 1.0f));
        }
        t.material = uint32_t(i % s.materials.size());
        s.triangles.push_back(t);
    }
    for (uint32_t i = 0; i < s.spheres.size(); ++i) s.spheres[i].material = 3;
    scene::Quadric q;  // the unit sphere as a quadric
    q.c = {1, 1, 1, 0, 0, 0, 0, 0, 0, -1};
    q.material = 4;
    s.quadrics.push_back(q);
    return s;
}

RcRenderParams Params(const scene::Scene& s) {
    RcRenderParams p{};
    p.nTriangles = uint32_t(s.triangles.size());
    p.nSpheres = uint32_t(s.spheres.size());
    p.nQuadrics = AnalyticRecords(s);
    p.nLights = uint32_t(s.lights.size());
    p.maxDepth = 3;
    p.minWeight = 0.05f;
    p.ambient = {0.05f, 0.06f, 0.07f, 0.0f};
    p.background = {0.1f, 0.2f, 0.3f, 0.0f};
    return p;
}

struct Batch {
    std::vector<RcRay> rays;
    std::vector<RcRayInfo> infos;
    std::vector<RcHit> hits;
};

// The first 64 hits on triangle 0 (lanes of one material), then half the hits on triangles (ids
// below nTriangles), the others on any primitive.
Batch MadeUpHits(uint32_t n, uint32_t nTriangles, uint32_t nPrimitives) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f), dir(-1.0f, 1.0f);
    std::uniform_int_distribution<uint32_t> prim(0, nPrimitives - 1), tri(0, nTriangles - 1),
        depth(0, 4);
    Batch b;
    for (uint32_t i = 0; i < n; ++i) {
        glm::vec3 d(dir(rng), dir(rng), dir(rng));
        d = glm::normalize(d + glm::vec3(0.0f, 0.0f, 0.01f));
        b.rays.push_back(
            {{4 * dir(rng), 4 * dir(rng), 4 * dir(rng), 0.0f}, {d.x, d.y, d.z, 1e30f}});
        const float w = i % 7 == 0 ? 0.04f : unit(rng);
        b.infos.push_back(
            {{w, w * unit(rng), w * unit(rng), 1.0f}, depth(rng), RC_RAY_REFLECTION, 0, 0});
        float u = unit(rng), v = unit(rng);
        if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
        b.hits.push_back({3.0f * unit(rng),
                          i % 9 == 0 ? RC_NO_HIT : (i < 64 ? 0 : (i % 2 ? tri(rng) : prim(rng))), u,
                          v});
    }
    return b;
}

struct Outputs {
    std::vector<uint8_t> radiance, normals, shadow, contribution, secondary, info, spawned;
};

std::vector<uint8_t> Bytes(const cl::Buffer& b) {
    std::vector<uint8_t> out(b.getInfo<CL_MEM_SIZE>());
    TestContext().queue().enqueueReadBuffer(b, CL_TRUE, 0, out.size(), out.data());
    return out;
}

Outputs Shade(const cl::Program& program, const SceneBuffers& scene, const Batch& batch,
              bool withInfos, size_t raysPerItem) {
    const uint32_t n = uint32_t(batch.rays.size()), nLights = scene.hostParams.nLights;
    const cl::Buffer rays = UploadVector(TestContext(), batch.rays),
                     hits = UploadVector(TestContext(), batch.hits);
    ShadeBuffers shade = MakeShadeBuffers(TestContext(), n, nLights);
    if (withInfos) shade.rayInfo = UploadVector(TestContext(), batch.infos);
    // Filled, so that slots no kernel writes compare equal.
    for (const cl::Buffer* b :
         {&shade.radiance, &shade.normals, &shade.shadow.rays, &shade.shadow.contribution,
          &shade.secondary.rays, &shade.secondary.info, &shade.spawned}) {
        TestContext().queue().enqueueFillBuffer(*b, uint8_t(0xA5), 0, b->getInfo<CL_MEM_SIZE>());
    }
    // rc_shade16_ids takes 16 rays a work-item and an id list before the count, here none.
    const bool packets = raysPerItem == kPacketRays;
    cl::Kernel k(program, packets ? "rc_shade16_ids" : "rc_shade");
    cl_uint a = 0;
    const auto arg = [&](const auto& v) { k.setArg(a++, v); };
    arg(rays), arg(shade.rayInfo), arg(hits);
    if (packets) arg(cl::Buffer());
    arg(n), arg(scene.triangles), arg(scene.triangleShading), arg(scene.spheres);
    arg(scene.quadrics), arg(scene.materials), arg(scene.lights), arg(scene.params);
    arg(shade.radiance), arg(shade.normals), arg(shade.shadow.rays), arg(shade.shadow.contribution);
    arg(shade.secondary.rays), arg(shade.secondary.info), arg(shade.spawned);
    KernelTimer timer;
    Launch(TestContext(), k, (n + raysPerItem - 1) / raysPerItem, timer);
    return {Bytes(shade.radiance),       Bytes(shade.normals),
            Bytes(shade.shadow.rays),    Bytes(shade.shadow.contribution),
            Bytes(shade.secondary.rays), Bytes(shade.secondary.info),
            Bytes(shade.spawned)};
}

TEST(Shade16, WritesWhatTheScalarKernelWrites) {
    const scene::Scene s = MixedScene();
    const RcRenderParams params = Params(s);
    const cl::Program program = BuildRenderProgram(TestContext());
    const SceneBuffers scene(TestContext(), s, params);
    const Batch batch = MadeUpHits(4001, uint32_t(s.triangles.size()), s.PrimitiveCount());
    for (bool withInfos : {true, false}) {
        SCOPED_TRACE(withInfos ? "with infos" : "eye rays without infos");
        const Outputs want = Shade(program, scene, batch, withInfos, 1);
        const Outputs got = Shade(program, scene, batch, withInfos, kPacketRays);
        EXPECT_EQ(got.radiance, want.radiance);
        EXPECT_EQ(got.normals, want.normals);
        EXPECT_EQ(got.shadow, want.shadow);
        EXPECT_EQ(got.contribution, want.contribution);
        EXPECT_EQ(got.secondary, want.secondary);
        EXPECT_EQ(got.info, want.info);
        EXPECT_EQ(got.spawned, want.spawned);
        // The batch reaches every branch: both secondary kinds and lit and unlit slots.
        size_t reflected = 0, refracted = 0;
        for (size_t i = 0; i < want.spawned.size(); i += 2) {
            reflected += want.spawned[i] == 1;
            refracted += want.spawned[i + 1] == 1;
        }
        EXPECT_GT(reflected, 100u);
        EXPECT_GT(refracted, 100u);
    }
}

}  // namespace
}  // namespace rayclass::render
