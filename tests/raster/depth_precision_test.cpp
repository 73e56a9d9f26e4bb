// Depth precision: the id buffers differ only where two hits lie within one depth quantum, and how
// many such pixels there are follows the distance-to-depth factor.
#include "raster_support.h"
#include "rayclass/scene/loader.h"

namespace rayclass::raster {
namespace {

using namespace testing_support;

TEST(RasterDepthPrecision, MismatchesFollowTheDepthScale) {
    RC_REQUIRE_GL();
    scene::Scene scene = scene::LoadScene(SceneDir() / "cornell.json");
    scene.camera.width = 200;
    scene.camera.height = 150;
    const std::vector<RcHit> kernel = KernelHits(scene);
    const RcCamera cam = render::CameraBasis(scene.camera).ToDevice();

    // 32-bit float depth with the derived power-of-two factor: distances compare exactly.
    double derived = 0;
    {
        RasterPass pass(*gl, scene);
        const HitComparison cmp = CompareHits(pass.Render(cam), kernel);
        derived = pass.DepthScale();
        EXPECT_EQ(cmp.idMismatch, 0u);
        EXPECT_EQ(std::log2(derived), std::round(std::log2(derived)));
    }
    // 16-bit fixed point: one quantum is 1 / (scale * 65535) world units, so dividing the scale
    // by 4 makes quanta 4 times coarser and more pixels ambiguous (wall corners, contact points).
    size_t previous = 0;
    std::vector<size_t> counts;
    for (double divisor : {1.0, 4.0, 16.0}) {
        RasterOptions options;
        options.depthBits = 16;
        options.depthScale = derived / divisor;
        RasterPass pass(*gl, scene, options);
        const std::vector<RcHit> raster = pass.Render(cam);
        const HitComparison cmp = CompareHits(raster, kernel);
        const double quantum = 1.0 / (options.depthScale * 65535.0);
        std::printf("16-bit depth, scale %.3g (quantum %.3g): %zu id mismatches of %zu pixels, "
                    "%zu hit vs miss\n",
                    options.depthScale, quantum, cmp.idMismatch, cmp.pixels, cmp.missVsHit);
        EXPECT_EQ(cmp.missVsHit, 0u);
        for (size_t i : cmp.mismatchPixels) {
            // The raster's hit is never nearer than the true nearest, and at most one quantum
            // (plus rounding to the nearest quantum) farther.
            EXPECT_GE(raster[i].t, kernel[i].t) << "pixel " << i;
            EXPECT_LE(raster[i].t - kernel[i].t, 1.01 * quantum) << "pixel " << i;
        }
        EXPECT_GE(cmp.idMismatch, previous);
        EXPECT_LE(cmp.idMismatch, cmp.pixels / 50) << "a small fraction of the image";
        previous = cmp.idMismatch;
        counts.push_back(cmp.idMismatch);
    }
    EXPECT_GT(counts.back(), counts.front()) << "coarser quanta should cost pixels";
}

}  // namespace
}  // namespace rayclass::raster
