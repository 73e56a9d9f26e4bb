// Patch boxes in the raster pass: every pixel's id, distance and (u, v) equal the OpenCL eye-ray
// kernel's brute force (rc_intersect_patch_box), with every hull and with front-to-back slabs.
#include "raster_support.h"
#include "rayclass/image/compare.h"
#include "rayclass/render/cl_renderer.h"
#include "rayclass/scene/loader.h"

namespace rayclass::raster {
namespace {

using namespace testing_support;

struct PatchCase {
    std::string file;
    uint32_t width, height;
    Hull hull;
    uint32_t slabs;
};

void PrintTo(const PatchCase& c, std::ostream* os) { *os << c.file << "/" << c.slabs; }

const PatchCase kCases[] = {
    {"teapot.json", 96, 72, Hull::Auto, 1},
    {"teapot.json", 96, 72, Hull::Sphere, 1},
    {"teapot.json", 96, 72, Hull::Billboard, 1},
    {"teapot.json", 96, 72, Hull::Auto, 4},
    {"tests/nurbs_sphere.json", 64, 48, Hull::Auto, 1},
    {"tests/nurbs_sphere.json", 64, 48, Hull::Billboard, 3},
    {"tests/nurbs_torus.json", 64, 48, Hull::Auto, 1},
    {"tests/nurbs_torus.json", 64, 48, Hull::Sphere, 1},
};

class PatchRasterMatchesKernel : public testing::TestWithParam<PatchCase> {};

TEST_P(PatchRasterMatchesKernel, HitsAgreeBitForBit) {
    RC_REQUIRE_GL();
    const PatchCase& c = GetParam();
    scene::Scene scene = scene::LoadScene(SceneDir() / c.file);
    scene.camera.width = c.width;
    scene.camera.height = c.height;
    ASSERT_FALSE(scene.patchBoxes.empty());
    const std::vector<RcHit> kernel = KernelHits(scene);
    size_t patchHits = 0;
    for (const RcHit& h : kernel)
        patchHits += h.prim != RC_NO_HIT && h.prim >= scene.PatchBoxBase();
    EXPECT_GT(patchHits, size_t(c.width) * c.height / 10) << "the patches should be visible";
    RasterOptions options;
    options.hull = c.hull;
    options.slabs = c.slabs;
    RasterPass pass(*gl, scene, options);
    const std::vector<RcHit> raster = pass.Render(render::CameraBasis(scene.camera).ToDevice());
    const HitComparison cmp = CompareHits(raster, kernel);
    std::printf(
        "%s/%s/%u: %zu patch hits, id mismatch %zu (miss vs hit %zu), t differs %zu, "
        "uv differs %zu\n",
        c.file.c_str(), HullName(c.hull), c.slabs, patchHits, cmp.idMismatch, cmp.missVsHit,
        cmp.tDiffer, cmp.uvDiffer);
    EXPECT_EQ(cmp.idMismatch, 0u);
    EXPECT_EQ(cmp.tDiffer, 0u);
    EXPECT_EQ(cmp.uvDiffer, 0u);
}

INSTANTIATE_TEST_SUITE_P(Scenes, PatchRasterMatchesKernel, testing::ValuesIn(kCases),
                         [](const auto& info) {
                             const PatchCase& c = info.param;
                             return std::string(std::filesystem::path(c.file).stem()) + "_" +
                                    HullName(c.hull) + "_slabs" + std::to_string(c.slabs);
                         });

// The whole render with the raster pass's eye hits is the kernel path's image, pixel for pixel.
TEST(PatchRaster, TeapotRenderEqualsTheKernelPaths) {
    RC_REQUIRE_GL();
    scene::Scene scene = scene::LoadScene(SceneDir() / "teapot.json");
    scene.camera.width = 64;
    scene.camera.height = 48;
    render::RenderOptions options;
    options.aovs = true;
    options.progress = false;
    render::RenderStats rasterStats, kernelStats;
    RasterEyeHits eyeHits(*gl, RasterOptions{});
    const image::Image raster =
        render::ClRenderer(Cl(), scene, options, &eyeHits).Render(rasterStats);
    EXPECT_EQ(rasterStats.eyeRays, "raster");
    const image::Image kernel = render::ClRenderer(Cl(), scene, options).Render(kernelStats);
    const image::ImageComparison same = image::Compare(raster, kernel);
    ASSERT_TRUE(same.hasIds);
    EXPECT_EQ(same.maxAbsError, 0.0);
    EXPECT_EQ(same.idMismatchPixels, 0u);
    EXPECT_EQ(rasterStats.RaysTotal(), kernelStats.RaysTotal());
}

}  // namespace
}  // namespace rayclass::raster
