// Depth precision: the id buffers differ only where two hits lie within one depth quantum, and how
// many such pixels there are follows the distance-to-depth factor; DepthWarnings names exactly the
// settings that lose hits or swap ids.
#include <filesystem>

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
        EXPECT_TRUE(DepthWarnings(scene, scene.camera.position, {}).empty());
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
        std::printf(
            "16-bit depth, scale %.3g (quantum %.3g): %zu id mismatches of %zu pixels, "
            "%zu hit vs miss\n",
            options.depthScale, quantum, cmp.idMismatch, cmp.pixels, cmp.missVsHit);
        EXPECT_EQ(cmp.missVsHit, 0u);
        // Every one of these settings merges close surfaces, and only that is wrong with it.
        const std::vector<std::string> warnings =
            DepthWarnings(scene, scene.camera.position, options);
        ASSERT_EQ(warnings.size(), 1u);
        EXPECT_NE(warnings[0].find("16-bit depth steps are"), std::string::npos) << warnings[0];
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

// Two parallel 16 x 16 squares facing the camera at distance 10, kGap apart, filling the view.
// The farther one has the lower ids, so it is drawn first and keeps the pixels where both
// surfaces fall into one depth step.
constexpr float kGap = 6e-5f;

scene::Scene CloseSurfaces() {
    scene::Scene s;
    s.camera.position = glm::vec3(0.0f);
    s.camera.lookAt = glm::vec3(0.0f, 0.0f, -1.0f);
    s.camera.width = 64;
    s.camera.height = 48;
    for (const float z : {-10.0f - kGap, -10.0f}) {
        const glm::vec3 a(-8, -8, z), b(8, -8, z), c(8, 8, z), d(-8, 8, z);
        s.triangles.push_back({{a, b, c}, {}, false, 0, 0});
        s.triangles.push_back({{a, c, d}, {}, false, 0, 0});
    }
    return s;
}

TEST(RasterDepthPrecision, WarningsNameTheSettingsThatLoseHitsOrSwapIds) {
    const scene::Scene scene = CloseSurfaces();
    const glm::vec3 eye = scene.camera.position;
    // Depth range sqrt(8^2 + 8^2 + 10.00006^2) = 15.1: the automatic scale is 2^-4.
    EXPECT_TRUE(DepthWarnings(scene, eye, {}).empty());
    RasterOptions bits16, bits24, lossy, rounding;
    bits16.depthBits = 16;  // step 1 / (2^-4 * 65535) = 2.4e-4 > kGap
    bits24.depthBits = 24;  // step 9.5e-7, below 15.1 * 2^-20 = 1.4e-5
    lossy.depthScale = 0.125;
    rounding.depthScale = 0.05;
    EXPECT_EQ(DepthWarnings(scene, eye, bits16),
              std::vector<std::string>{
                  "16-bit depth steps are 0.000244 world units at depth scale 2^-4 (over "
                  "2^-20 of the scene's depth range 15.1): surfaces closer than a step may swap "
                  "ids"});
    EXPECT_TRUE(DepthWarnings(scene, eye, bits24).empty());
    EXPECT_EQ(DepthWarnings(scene, eye, lossy),
              std::vector<std::string>{"depth scale 2^-3 loses hits farther than 8 from the eye "
                                       "(the scene reaches 15.1)"});
    EXPECT_EQ(DepthWarnings(scene, eye, rounding),
              std::vector<std::string>{"depth scale 0.05 is not a power of two: float depth "
                                       "rounds distances, so surfaces within a float step may "
                                       "swap ids"});

    RC_REQUIRE_GL();
    const std::vector<RcHit> kernel = KernelHits(scene);
    for (const RcHit& hit : kernel) ASSERT_GE(hit.prim, 2u) << "the kernel sees the near square";
    const RcCamera cam = render::CameraBasis(scene.camera).ToDevice();
    const auto compare = [&](const RasterOptions& options) {
        RasterPass pass(*gl, scene, options);
        return CompareHits(pass.Render(cam), kernel);
    };
    EXPECT_EQ(compare({}).idMismatch, 0u);
    EXPECT_EQ(compare(bits24).idMismatch, 0u);
    EXPECT_EQ(compare(rounding).idMismatch, 0u) << "kGap is far above a float step";
    // Every hit lies beyond 1 / 0.125 = 8: all are lost.
    const HitComparison lost = compare(lossy);
    EXPECT_EQ(lost.missVsHit, lost.pixels);
    // 16 bits: the squares share a depth step where the nearer one's depth does not round up
    // past the farther one's, about 1 - kGap / step = 75 % of the pixels (measured: 2400 of
    // 3072, 78 %); there the farther square, drawn first, keeps the pixel.
    RasterPass pass16(*gl, scene, bits16);
    const std::vector<RcHit> raster16 = pass16.Render(cam);
    const HitComparison merged = CompareHits(raster16, kernel);
    for (size_t i : merged.mismatchPixels) EXPECT_LT(raster16[i].prim, 2u) << "pixel " << i;
    std::printf(
        "[depth] close surfaces %g apart, 16-bit step 0.000244: %zu id mismatches of %zu "
        "pixels\n",
        double(kGap), merged.idMismatch, merged.pixels);
    EXPECT_EQ(merged.missVsHit, 0u);
    EXPECT_GE(merged.idMismatch, merged.pixels / 2);
    EXPECT_LE(merged.idMismatch, merged.pixels * 9 / 10);
}

TEST(RasterDepthPrecision, DefaultSettingsAreSafeOnEveryShippedScene) {
    size_t scenes = 0;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(SceneDir())) {
        if (entry.path().extension() != ".json") continue;
        const scene::Scene scene = scene::LoadScene(entry.path());
        EXPECT_EQ(DepthWarnings(scene, scene.camera.position, {}), std::vector<std::string>{})
            << entry.path();
        ++scenes;
    }
    EXPECT_GE(scenes, 8u);
}

}  // namespace
}  // namespace rayclass::raster
