// The classified query's hierarchies across generations: a generation's rays are classified as
// by a new query (BeginGeneration forgets the splits earlier generations made), while a later
// batch of the same generation still lands in the hierarchy its earlier batches built. The
// primitive tests a query reports tell the two apart: the same rays cost a different number of
// tests when they are routed through splits made for other rays. Every answer is also checked
// against the brute-force query's.
#include "rayclass/render/classified_query.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>
#include <vector>

#include "clrt/device.h"
#include "quad.h"
#include "query_io.h"
#include "rayclass/classify/hierarchy.h"
#include "rayclass/clrt/context.h"
#include "rayclass/render/auto_query.h"
#include "rayclass/render/brute_query.h"
#include "rayclass/render/bvh_query.h"
#include "rayclass/render/device_scene.h"
#include "shadow_ray.h"

namespace rayclass::render {
namespace {

using clrt::testing::TestContext;

// Two nested boxes, [-4, 4]^3 and [-1, 1]^3, their walls tiled with squares (16 x 16 and 8 x 8 a
// wall, 3,840 triangles), lit by one light between them.
void AddTiledBox(scene::Scene& s, float half, int tiles) {
    for (int axis = 0; axis < 3; ++axis) {
        for (float side : {-half, half}) {
            for (int i = 0; i < tiles; ++i) {
                for (int j = 0; j < tiles; ++j) {
                    auto at = [&](int a, int b) {
                        glm::vec3 p;
                        p[axis] = side;
                        p[(axis + 1) % 3] = half * (2.0f * float(a) / float(tiles) - 1.0f);
                        p[(axis + 2) % 3] = half * (2.0f * float(b) / float(tiles) - 1.0f);
                        return p;
                    };
                    AddQuad(s, at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                }
            }
        }
    }
}

scene::Scene NestedTiledBoxes() {
    scene::Scene s;
    AddTiledBox(s, 4.0f, 16);
    AddTiledBox(s, 1.0f, 8);
    scene::PointLight light;
    light.position = {-3.0f, -2.5f, -2.0f};
    s.lights.push_back(light);
    return s;
}

// Rays from a small cube of origins in random directions: two seeds give two sets of rays in
// the same region of ray space, so the second set runs through the first one's splits.
std::vector<RcRay> RaysNearOneCorner(uint32_t seed, uint32_t n) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> pos(1.0f, 2.0f), dir(-1.0f, 1.0f);
    std::vector<RcRay> rays;
    while (rays.size() < n) {
        const glm::vec3 d(dir(rng), dir(rng), dir(rng));
        if (glm::length(d) < 0.1f || glm::length(d) > 1.0f) continue;
        const glm::vec3 u = glm::normalize(d);
        rays.push_back({{pos(rng), pos(rng), pos(rng), 1e-4f}, {u.x, u.y, u.z, INFINITY}});
    }
    return rays;
}

// Segments of length 3 along `rays`, as shadow rays. Toward a point light, shadow rays are
// classified from the light, where splits of their directions alone come out the same in a
// new hierarchy and in an old one; segments are classified from their origins, as nearest-hit
// rays are.
std::vector<RcRay> Segments(std::vector<RcRay> rays) {
    for (RcRay& r : rays) r.direction.w = 3.0f;
    return rays;
}

struct Fixture {
    scene::Scene scene = NestedTiledBoxes();
    cl::Program program = BuildRenderProgram(TestContext());
    SceneBuffers buffers{TestContext(), scene, Params()};

    RcRenderParams Params() const {
        RcRenderParams p{};
        p.nTriangles = uint32_t(scene.triangles.size());
        p.nLights = uint32_t(scene.lights.size());
        p.maxDepth = 6;
        p.minWeight = 0.001f;
        return p;
    }

    std::unique_ptr<RayQuery> NewQuery() const {
        return MakeClassifiedQuery(TestContext(), program, buffers, scene,
                                   classify::Params::ForScene(scene), KernelStyle::kFragment);
    }

    // Nearest hits of a batch, shaded as the renderer shades them; returns the tests done.
    uint64_t Nearest(RayQuery& q, const std::vector<RcRay>& rays,
                     std::vector<RcHit>* hitsOut = nullptr) const {
        return NearestHits(TestContext(), q, rays, Params().nLights, hitsOut);
    }

    uint64_t Occluded(RayQuery& q, const std::vector<RcRay>& rays) const {
        uint64_t tests = 0;
        BlockedAnswers(TestContext(), q, rays, &tests);
        return tests;
    }
};

// Same primitive and distance, ray by ray.
void ExpectSameHits(const std::vector<RcHit>& got, const std::vector<RcHit>& want) {
    ASSERT_EQ(got.size(), want.size());
    size_t hits = 0;
    for (size_t i = 0; i < want.size(); ++i) {
        ASSERT_EQ(got[i].prim, want[i].prim) << "ray " << i;
        if (want[i].prim == RC_NO_HIT) continue;
        ++hits;
        ASSERT_EQ(got[i].t, want[i].t) << "ray " << i;
    }
    EXPECT_GT(hits, want.size() / 2);
}

void BeginGeneration(RayQuery& q, uint32_t generation, const std::vector<RcRay>& rays) {
    KernelTimer timer;
    q.BeginGeneration(generation, UploadVector(TestContext(), rays), uint32_t(rays.size()), timer);
}

TEST(ClassifiedQuery, EachGenerationIsClassifiedAsByANewQuery) {
    const Fixture f;
    const std::vector<RcRay> first = RaysNearOneCorner(1, 20000),
                             second = RaysNearOneCorner(2, 20000);
    const std::vector<RcRay> firstShadow = Segments(first), secondShadow = Segments(second);

    std::vector<RcHit> freshHits, laterHits;
    const uint64_t fresh = f.Nearest(*f.NewQuery(), second, &freshHits);
    const uint64_t freshShadow = f.Occluded(*f.NewQuery(), secondShadow);

    // The second set as a later batch of the first set's generation: it runs through the first
    // set's splits and costs other tests (else this test could not tell the cases apart).
    const std::unique_ptr<RayQuery> shared = f.NewQuery();
    f.Nearest(*shared, first);
    f.Occluded(*shared, firstShadow);
    ASSERT_NE(f.Nearest(*shared, second), fresh);
    ASSERT_NE(f.Occluded(*shared, secondShadow), freshShadow);

    // The second set as the next generation.
    const std::unique_ptr<RayQuery> q = f.NewQuery();
    BeginGeneration(*q, 0, first);
    f.Nearest(*q, first);
    f.Occluded(*q, firstShadow);
    BeginGeneration(*q, 1, second);
    EXPECT_EQ(f.Nearest(*q, second, &laterHits), fresh);
    EXPECT_EQ(f.Occluded(*q, secondShadow), freshShadow);
    // Both answer as brute force does, hit for hit and shadow ray for shadow ray.
    const std::unique_ptr<RayQuery> brute =
        MakeBruteForceQuery(TestContext(), f.program, f.buffers);
    const std::vector<RcHit> bruteHits = NearestHits(TestContext(), *brute, second);
    ExpectSameHits(freshHits, bruteHits);
    ExpectSameHits(laterHits, bruteHits);
    const std::vector<uint8_t> bruteBlocked = BlockedAnswers(TestContext(), *brute, secondShadow);
    EXPECT_EQ(BlockedAnswers(TestContext(), *f.NewQuery(), secondShadow), bruteBlocked);

    // --accel auto passes the new generation on to its classification. Its sample of the other
    // query is timed; brute force, some 3,840 tests a ray, never wins it, so the classification
    // answers every batch here.
    const std::unique_ptr<RayQuery> a = MakeAutoQuery(TestContext(), f.NewQuery(), [&f] {
        return MakeBruteForceQuery(TestContext(), f.program, f.buffers);
    });
    BeginGeneration(*a, 0, first);
    f.Nearest(*a, first);
    f.Occluded(*a, firstShadow);
    BeginGeneration(*a, 1, second);
    std::vector<RcHit> autoHits;
    EXPECT_EQ(f.Nearest(*a, second, &autoHits), fresh);
    ExpectSameHits(autoHits, bruteHits);
    EXPECT_EQ(f.Occluded(*a, secondShadow), freshShadow);
}

// Shadow rays toward the nested boxes' light: half from points just beside it, on the side away
// from the inner box, whose segments reach no primitive (their leaves' lists are empty), half
// from the inner box's walls, many of them blocked by the box itself.
std::vector<RcRay> ShadowRaysNearAndFar(const scene::Scene& s, uint32_t n) {
    const glm::vec3 light = s.lights[0].position;
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> unit(-1.0f, 1.0f), near(0.05f, 0.3f);
    std::vector<RcRay> rays;
    while (rays.size() < n) {
        glm::vec3 o(unit(rng), unit(rng), unit(rng));
        if (rays.size() % 2 == 0) {
            const glm::vec3 away(-std::abs(o.x), -std::abs(o.y), -std::abs(o.z));
            if (glm::length(away) < 0.1f) continue;
            o = light + near(rng) * glm::normalize(away);
        } else {
            o[int(rays.size() / 2 % 3)] = rays.size() % 4 == 1 ? 1.0f : -1.0f;
        }
        rays.push_back(ShadowRay(o, light));
    }
    return rays;
}

// The blocked flags of a shadow batch, the flags' buffer set before the query: every flag is
// the query's, none left from before.
std::vector<uint8_t> BlockedOverStaleFlags(RayQuery& q, const std::vector<RcRay>& rays) {
    const uint32_t n = uint32_t(rays.size());
    const cl::Buffer blocked(TestContext().context(), CL_MEM_READ_WRITE, n);
    TestContext().queue().enqueueFillBuffer(blocked, uint8_t(1), 0, n);
    KernelTimer timer;
    q.Occluded(UploadVector(TestContext(), rays), rays, blocked, timer);
    std::vector<uint8_t> out(n);
    TestContext().queue().enqueueReadBuffer(blocked, CL_TRUE, 0, n, out.data());
    return out;
}

TEST(ClassifiedQuery, ShadowRaysOfLeavesWithoutCandidatesAreUnblocked) {
    const Fixture f;
    const std::vector<RcRay> rays = ShadowRaysNearAndFar(f.scene, 8192);
    // The classification does leave some rays with no candidates.
    const classify::LeafBatch batch =
        classify::Hierarchy(f.scene, classify::Params::ForScene(f.scene))
            .Classify(classify::RayView(rays.data(), rays.size(), sizeof(RcRay)),
                      classify::RayUse::kAnyHit);
    size_t raysWithout = 0;
    for (const RcLeaf& leaf : batch.leaves) raysWithout += leaf.candCount == 0 ? leaf.rayCount : 0;
    ASSERT_GT(raysWithout, rays.size() / 4);

    const std::unique_ptr<RayQuery> brute =
        MakeBruteForceQuery(TestContext(), f.program, f.buffers);
    const std::vector<uint8_t> want = BlockedAnswers(TestContext(), *brute, rays);
    const size_t blocked = size_t(std::count(want.begin(), want.end(), uint8_t(1)));
    ASSERT_GT(blocked, rays.size() / 8);
    ASSERT_LT(blocked, rays.size() / 2);
    EXPECT_EQ(BlockedOverStaleFlags(*f.NewQuery(), rays), want);
}

// Everything shading writes for a batch of eye rays: the hits, radiance and normals, the shadow
// slots and the secondary rays with their infos and flags.
struct ShadeOutputs {
    std::vector<RcHit> hits;
    std::vector<rc_float4> radiance, normals, contribution;
    std::vector<RcRay> shadow, secondary;
    std::vector<RcRayInfo> secondaryInfo;
    std::vector<uint8_t> spawned;
};

template <typename T>
std::vector<T> ReadAll(const cl::Buffer& b, size_t n) {
    std::vector<T> v(n);
    TestContext().queue().enqueueReadBuffer(b, CL_TRUE, 0, n * sizeof(T), v.data());
    return v;
}

template <typename T>
bool SameBytes(const std::vector<T>& a, const std::vector<T>& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

// `rays` as eye rays through q, shaded by the query's own kernels or, when it shades nothing
// itself, by rc_shade16_ids as the renderer does (or by the scalar rc_shade where `scalarShade`);
// with explicit eye infos or with none (the renderer's generation 0), with the shading normals
// wanted or not.
ShadeOutputs ShadeEyeRays(const cl::Program& program, const SceneBuffers& scene,
                          const RcRenderParams& params, RayQuery& q, const std::vector<RcRay>& rays,
                          bool withInfos, bool writeNormals = true, bool scalarShade = false) {
    const uint32_t n = uint32_t(rays.size()), nLights = params.nLights;
    std::vector<RcRayInfo> info(n);
    for (RcRayInfo& i : info) {
        i.weight = {1.0f, 1.0f, 1.0f, 1.0f};
        i.kind = RC_RAY_EYE;
    }
    const cl::Buffer rayBuf = UploadVector(TestContext(), rays);
    const cl::Buffer hits(TestContext().context(), CL_MEM_READ_WRITE, n * sizeof(RcHit));
    ShadeBuffers shade = MakeShadeBuffers(TestContext(), n, nLights);
    if (withInfos) shade.rayInfo = UploadVector(TestContext(), info);
    shade.writeNormals = writeNormals;
    // Zeroed, so that slots no kernel writes compare equal.
    for (const cl::Buffer* b :
         {&shade.radiance, &shade.normals, &shade.shadow.rays, &shade.shadow.contribution,
          &shade.secondary.rays, &shade.secondary.info, &shade.spawned}) {
        TestContext().queue().enqueueFillBuffer(*b, uint8_t(0), 0, b->getInfo<CL_MEM_SIZE>());
    }
    KernelTimer timer;
    std::unique_ptr<PreparedBatch> prepared = q.Prepare(rayBuf, n, TestContext().queue(), {});
    const bool shaded = q.Intersect(rayBuf, n, prepared.get(), hits, shade, timer).shaded;
    q.Recycle(std::move(prepared));
    if (!shaded) {
        cl::Kernel k(program, scalarShade ? "rc_shade" : "rc_shade16_ids");
        cl_uint a = 0;
        auto arg = [&](const auto& v) { k.setArg(a++, v); };
        arg(rayBuf), arg(shade.rayInfo), arg(hits);
        if (!scalarShade) arg(cl::Buffer());  // no id list: every ray
        arg(n), arg(scene.triangles);
        arg(scene.triangleShading), arg(scene.spheres), arg(scene.quadrics), arg(scene.materials);
        arg(scene.lights), arg(scene.params), arg(shade.radiance);
        arg(shade.NormalsOut());
        arg(shade.shadow.rays), arg(shade.shadow.contribution), arg(shade.secondary.rays);
        arg(shade.secondary.info), arg(shade.spawned);
        const size_t items = scalarShade ? n : (n + 15) / 16;  // rc_shade16_ids: 16 rays an item
        TestContext().queue().enqueueNDRangeKernel(
            k, cl::NullRange, cl::NDRange(clrt::RoundUp(items, 64)), cl::NDRange(64));
    }
    ShadeOutputs out;
    out.hits = ReadAll<RcHit>(hits, n);
    out.radiance = ReadAll<rc_float4>(shade.radiance, n);
    out.normals = ReadAll<rc_float4>(shade.normals, n);
    out.shadow = ReadAll<RcRay>(shade.shadow.rays, size_t(n) * nLights);
    out.contribution = ReadAll<rc_float4>(shade.shadow.contribution, size_t(n) * nLights);
    out.secondary = ReadAll<RcRay>(shade.secondary.rays, SecondarySlots(n));
    out.secondaryInfo = ReadAll<RcRayInfo>(shade.secondary.info, SecondarySlots(n));
    out.spawned = ReadAll<uint8_t>(shade.spawned, 2 * size_t(n));
    return out;
}

// Generation 0 writes no ray infos: every shading kernel, given none or eye infos, shades
// byte for byte as the scalar rc_shade shades brute force's hits from explicit eye infos
// (weight 1, depth 0), with one light and with two, in every kernel style and by rc_shade16_ids
// after a BVH query.
// Without the normals wanted, the same is shaded, and no normals are written.
TEST(ClassifiedQuery, EyeRaysWithoutInfosShadeAsWithEyeInfos) {
    for (int nLights : {1, 2}) {
        scene::Scene s = NestedTiledBoxes();
        // Mirror walls, so that secondary rays are spawned.
        scene::Material mirror;
        mirror.kd = glm::vec3(0.3f);
        mirror.kr = glm::vec3(0.5f);
        s.materials.push_back(mirror);
        for (size_t t = 0; t < s.triangles.size(); t += 3) {
            s.triangles[t].material = uint32_t(s.materials.size() - 1);
        }
        if (nLights == 2) {
            scene::PointLight second;
            second.position = {2.5f, 3.0f, -1.5f};
            s.lights.push_back(second);
        }
        RcRenderParams params{};
        params.nTriangles = uint32_t(s.triangles.size());
        params.nLights = uint32_t(s.lights.size());
        params.maxDepth = 6;
        params.minWeight = 0.001f;
        const cl::Program program = BuildRenderProgram(TestContext());
        const SceneBuffers buffers(TestContext(), s, params);
        const std::vector<RcRay> rays = RaysNearOneCorner(3, 3000);
        std::vector<std::unique_ptr<RayQuery>> queries;
        for (KernelStyle style : {KernelStyle::kScalar, KernelStyle::kVertex,
                                  KernelStyle::kFragment, KernelStyle::kAuto}) {
            queries.push_back(MakeClassifiedQuery(TestContext(), program, buffers, s,
                                                  classify::Params::ForScene(s), style));
        }
        queries.push_back(MakeBvhQuery(TestContext(), program, buffers, s));
        // The oracle: brute-force hits shaded by rc_shade from explicit eye infos.
        const std::unique_ptr<RayQuery> brute =
            MakeBruteForceQuery(TestContext(), program, buffers);
        const ShadeOutputs want =
            ShadeEyeRays(program, buffers, params, *brute, rays, true, true, true);
        size_t spawned = 0, lit = 0;
        for (uint8_t x : want.spawned) spawned += x;
        for (const rc_float4& c : want.contribution) lit += c.w > 0.0f;
        EXPECT_GT(spawned, rays.size() / 4);
        EXPECT_GT(lit, rays.size() / 4);
        for (const auto& q : queries) {
            SCOPED_TRACE(q->Name() + ", " + std::to_string(nLights) + " lights");
            const ShadeOutputs with = ShadeEyeRays(program, buffers, params, *q, rays, true);
            q->Reset();
            const ShadeOutputs without = ShadeEyeRays(program, buffers, params, *q, rays, false);
            for (const ShadeOutputs* got : {&with, &without}) {
                EXPECT_TRUE(SameBytes(got->hits, want.hits));
                EXPECT_TRUE(SameBytes(got->radiance, want.radiance));
                EXPECT_TRUE(SameBytes(got->normals, want.normals));
                EXPECT_TRUE(SameBytes(got->shadow, want.shadow));
                EXPECT_TRUE(SameBytes(got->contribution, want.contribution));
                EXPECT_TRUE(SameBytes(got->secondary, want.secondary));
                EXPECT_TRUE(SameBytes(got->secondaryInfo, want.secondaryInfo));
                EXPECT_TRUE(SameBytes(got->spawned, want.spawned));
            }

            q->Reset();
            const ShadeOutputs noNormals =
                ShadeEyeRays(program, buffers, params, *q, rays, false, false);
            EXPECT_TRUE(SameBytes(with.radiance, noNormals.radiance));
            EXPECT_TRUE(SameBytes(with.shadow, noNormals.shadow));
            EXPECT_TRUE(SameBytes(with.contribution, noNormals.contribution));
            EXPECT_TRUE(SameBytes(with.secondary, noNormals.secondary));
            EXPECT_TRUE(SameBytes(with.secondaryInfo, noNormals.secondaryInfo));
            EXPECT_TRUE(SameBytes(with.spawned, noNormals.spawned));
            const std::vector<rc_float4> zero(rays.size(), rc_float4{0, 0, 0, 0});
            EXPECT_TRUE(SameBytes(noNormals.normals, zero));
        }
    }
}

}  // namespace
}  // namespace rayclass::render
