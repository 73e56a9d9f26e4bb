// The raster pass against the OpenCL eye-ray kernel (rc_generate_eye_rays + rc_intersect_brute)
// on every shipped scene and on constructed corner cases.
#include <cmath>

#include "raster_support.h"
#include "rayclass/image/compare.h"
#include "rayclass/render/cl_renderer.h"
#include "rayclass/render/reference.h"
#include "rayclass/scene/loader.h"

namespace rayclass::raster {
namespace {

using namespace testing_support;

struct SceneCase {
    std::string file;
    uint32_t width, height;
};

void PrintTo(const SceneCase& c, std::ostream* os) { *os << c.file; }

const SceneCase kScenes[] = {
    {"cornell.json", 200, 150},
    {"tests/spheres.json", 160, 120},
    {"tests/quadrics.json", 160, 120},
    {"tests/glass.json", 160, 120},
};

class RasterMatchesKernel
    : public testing::TestWithParam<std::tuple<SceneCase, Hull>> {};

TEST_P(RasterMatchesKernel, IdBuffersAgree) {
    RC_REQUIRE_GL();
    const auto& [c, hull] = GetParam();
    scene::Scene scene = scene::LoadScene(SceneDir() / c.file);
    scene.camera.width = c.width;
    scene.camera.height = c.height;
    const std::vector<RcHit> kernel = KernelHits(scene);
    RasterOptions options;
    options.hull = hull;
    RasterPass pass(*gl, scene, options);
    const std::vector<RcHit> raster = pass.Render(render::CameraBasis(scene.camera).ToDevice());
    const HitComparison cmp = CompareHits(raster, kernel);
    std::printf("%s/%s: id mismatch %zu (miss vs hit %zu), t differs %zu, uv differs %zu\n",
                c.file.c_str(), HullName(hull), cmp.idMismatch, cmp.missVsHit, cmp.tDiffer,
                cmp.uvDiffer);
    EXPECT_EQ(cmp.idMismatch, 0u);
    EXPECT_EQ(cmp.tDiffer, 0u);
    EXPECT_EQ(cmp.uvDiffer, 0u);
}

INSTANTIATE_TEST_SUITE_P(
    Scenes, RasterMatchesKernel,
    testing::Combine(testing::ValuesIn(kScenes),
                     testing::Values(Hull::Auto, Hull::Sphere, Hull::Box, Hull::Billboard)),
    [](const auto& info) {
        std::string name = std::filesystem::path(std::get<0>(info.param).file).stem();
        return name + "_" + HullName(std::get<1>(info.param));
    });

}  // namespace
}  // namespace rayclass::raster

namespace rayclass::raster {
namespace {

using namespace testing_support;

// The whole render with generation 0 from the raster pass: within the foundation's bounds of the
// reference renderer (tests/render/render_test.cpp), and identical to the kernel path's image
// because both paths return the same hits bit for bit.
struct RenderCase {
    std::string file;
    uint32_t width, height;
    double maxRmse, maxMeanAbs;
    uint32_t maxIdMismatch;
};

void PrintTo(const RenderCase& c, std::ostream* os) { *os << c.file; }

const RenderCase kRenderCases[] = {
    {"cornell.json", 200, 150, 5e-4, 2e-5, 2},
    {"tests/spheres.json", 160, 120, 1e-3, 1e-5, 2},
    {"tests/quadrics.json", 160, 120, 1e-4, 2e-6, 2},
    {"tests/glass.json", 160, 120, 5e-4, 2e-5, 3},
};

class RasterRenderMatchesReference : public testing::TestWithParam<RenderCase> {};

TEST_P(RasterRenderMatchesReference, WithinBounds) {
    RC_REQUIRE_GL();
    const RenderCase& c = GetParam();
    scene::Scene scene = scene::LoadScene(SceneDir() / c.file);
    scene.camera.width = c.width;
    scene.camera.height = c.height;
    render::RenderOptions options;
    options.aovs = true;
    options.progress = false;
    render::RenderStats rasterStats, kernelStats, refStats;
    RasterEyeHits eyeHits(*gl, RasterOptions{});
    const image::Image raster =
        render::ClRenderer(Cl(), scene, options, &eyeHits).Render(rasterStats);
    EXPECT_EQ(rasterStats.eyeRays, "raster");
    const image::Image kernel = render::ClRenderer(Cl(), scene, options).Render(kernelStats);
    const image::Image ref = render::RenderReference(scene, options, refStats);
    const image::ImageComparison cmp = image::Compare(raster, ref);
    std::printf("%s: rmse %.3g mean_abs %.3g id_mismatch %llu\n", c.file.c_str(), cmp.rmse,
                cmp.meanAbsError, (unsigned long long)cmp.idMismatchPixels);
    EXPECT_LE(cmp.rmse, c.maxRmse);
    EXPECT_LE(cmp.meanAbsError, c.maxMeanAbs);
    ASSERT_TRUE(cmp.hasIds);
    EXPECT_LE(cmp.idMismatchPixels, c.maxIdMismatch);
    EXPECT_EQ(rasterStats.raysByKind["eye"], refStats.raysByKind["eye"]);
    const image::ImageComparison same = image::Compare(raster, kernel);
    EXPECT_EQ(same.maxAbsError, 0.0);
    EXPECT_EQ(same.idMismatchPixels, 0u);
    EXPECT_EQ(rasterStats.RaysTotal(), kernelStats.RaysTotal());
}

INSTANTIATE_TEST_SUITE_P(Scenes, RasterRenderMatchesReference, testing::ValuesIn(kRenderCases),
                         [](const auto& info) {
                             std::string name = std::filesystem::path(info.param.file).stem();
                             return name;
                         });

}  // namespace
}  // namespace rayclass::raster
