// The Embree Whitted renderer (bench/embree/whitted.h), the yardstick's whole-frame peer, renders
// the image rayclass renders: against the double-precision reference renderer on the default
// scene, and against rayclass's default render (itself checked against the reference, tests/render)
// on the benchmark scenes that scripts/yardstick times, at small sizes. Embree's watertight
// triangle test differs from rayclass's Moeller-Trumbore on edges, so the images are compared by
// error statistics and the first hits by a small count of mismatching pixels.
#include "whitted.h"

#include <gtest/gtest.h>

#include <cctype>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "rayclass/clrt/context.h"
#include "rayclass/image/compare.h"
#include "rayclass/render/cl_renderer.h"
#include "rayclass/render/reference.h"
#include "rayclass/scene/loader.h"
#include "test_device.h"

namespace rayclass::bench {
namespace {

scene::Scene TestScene(const std::string& file, uint32_t width, uint32_t height) {
    const char* source = std::getenv("RAYCLASS_SOURCE_DIR");
    scene::Scene scene =
        scene::LoadScene(std::filesystem::path(source ? source : ".") / "scenes" / file);
    scene.camera.width = width;
    scene.camera.height = height;
    return scene;
}

image::Image Embree(const scene::Scene& scene, WhittedStats& stats) {
    WhittedOptions options;
    options.threads = 2;
    options.ids = true;
    return RenderWhitted(scene, options, stats);
}

render::RenderOptions Options() {
    render::RenderOptions options;
    options.aovs = true;
    options.progress = false;
    return options;
}

struct Case {
    std::string file;
    uint32_t width, height;
    double maxRmse, maxMeanAbs, maxIdMismatch;  // id mismatch as a fraction of the pixels
};

void ExpectClose(const image::Image& embree, const image::Image& oracle, const Case& c) {
    const image::ImageComparison cmp = image::Compare(embree, oracle);
    std::printf("%s: rmse %.3g mean_abs %.3g id_mismatch %.3g\n", c.file.c_str(), cmp.rmse,
                cmp.meanAbsError, cmp.idMismatchFraction);
    EXPECT_LE(cmp.rmse, c.maxRmse);
    EXPECT_LE(cmp.meanAbsError, c.maxMeanAbs);
    ASSERT_TRUE(cmp.hasIds);
    EXPECT_LE(cmp.idMismatchFraction, c.maxIdMismatch);
}

// Bounds are 3-5x what was measured when they were set (rmse / mean abs / id mismatch fraction:
// cornell against the reference 1.2e-4 / 3.5e-6 / 0, against rayclass 1.4e-5 / 6.7e-7 / 0;
// sibenik_mirror 3.8e-7 / 6.6e-8 / 3.0e-3; conference_mirror 5.6e-6 / 1.5e-7 / 2.4e-4), so a
// difference in shading, offsets or spawned rays fails them.
TEST(EmbreeWhitted, MatchesTheReferenceOnTheDefaultScene) {
    const Case c{"cornell.json", 200, 150, 5e-4, 2e-5, 1e-4};
    const scene::Scene scene = TestScene(c.file, c.width, c.height);
    render::RenderStats refStats;
    const image::Image ref = render::RenderReference(scene, Options(), refStats);
    WhittedStats stats;
    ExpectClose(Embree(scene, stats), ref, c);
    EXPECT_EQ(stats.eye, refStats.raysByKind["eye"]);
    const double reflections = double(refStats.raysByKind["reflection"]);
    EXPECT_NEAR(double(stats.reflection), reflections, 0.01 * reflections + 20);
}

class EmbreeWhittedMatchesRayclass : public testing::TestWithParam<Case> {};

TEST_P(EmbreeWhittedMatchesRayclass, WithinBounds) {
    const Case& c = GetParam();
    const scene::Scene scene = TestScene(c.file, c.width, c.height);
    static clrt::Context ctx(TestDeviceSpec());
    render::RenderStats rcStats;
    const image::Image rc = render::ClRenderer(ctx, scene, Options()).Render(rcStats);
    WhittedStats stats;
    ExpectClose(Embree(scene, stats), rc, c);
    EXPECT_EQ(stats.eye, rcStats.raysByKind["eye"]);
    const double shadows = double(rcStats.raysByKind["shadow"]);
    EXPECT_NEAR(double(stats.shadow), shadows, 0.01 * shadows + 20);
    const double reflections = double(rcStats.raysByKind["reflection"]);
    EXPECT_NEAR(double(stats.reflection), reflections, 0.02 * reflections + 20);
}

INSTANTIATE_TEST_SUITE_P(
    BenchScenes, EmbreeWhittedMatchesRayclass,
    testing::Values(Case{"cornell.json", 200, 150, 1e-4, 5e-6, 1e-4},
                    Case{"bench/sibenik_mirror.json", 128, 96, 2e-6, 3e-7, 1e-2},
                    Case{"bench/conference_mirror.json", 128, 96, 3e-5, 8e-7, 1e-3}),
    [](const testing::TestParamInfo<Case>& info) {
        std::string name = std::filesystem::path(info.param.file).stem().string();
        for (char& ch : name) ch = std::isalnum(static_cast<unsigned char>(ch)) ? ch : '_';
        return name;
    });

}  // namespace
}  // namespace rayclass::bench
