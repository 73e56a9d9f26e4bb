// The raster pass against the OpenCL eye-ray kernel (rc_generate_eye_rays + rc_intersect_brute)
// on every shipped scene and on constructed corner cases.
#include <cmath>

#include "raster_support.h"
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
