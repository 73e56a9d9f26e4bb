// A frame's own program holds the kernels of one query only: every query must still find its own.
// The shared one holds every query's, for any --accel with the same build options.
#include "rayclass/render/frame_program.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <ostream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "rayclass/clrt/context.h"
#include "rayclass/image/compare.h"
#include "rayclass/render/cl_renderer.h"
#include "rayclass/scene/loader.h"
#include "test_device.h"

namespace rayclass::render {
namespace {

clrt::Context& SharedContext() {
    static clrt::Context ctx(TestDeviceSpec());
    return ctx;
}

scene::Scene SmallCornell() {
    const char* source = std::getenv("RAYCLASS_SOURCE_DIR");
    scene::Scene scene =
        scene::LoadScene(std::filesystem::path(source ? source : ".") / "scenes" / "cornell.json");
    scene.camera.width = 40;
    scene.camera.height = 30;
    return scene;
}

RenderOptions Quiet(Accel accel) {
    RenderOptions options;
    options.aovs = true;
    options.progress = false;
    options.accel = accel;
    return options;
}

// One test per query, so that a cold program cache compiles their programs in parallel runs.
struct QueryCase {
    std::string_view name;
    Accel accel;
};
void PrintTo(const QueryCase& c, std::ostream* os) { *os << c.name; }

class FrameProgramOfQuery : public ::testing::TestWithParam<QueryCase> {};

TEST_P(FrameProgramOfQuery, RendersBruteForcesImageFromItsOwnProgram) {
    // Every query's hits are exact (the same triangle test), so each renders brute force's image
    // to the bit; a kernel missing from its program would fail the render instead.
    const scene::Scene scene = SmallCornell();
    RenderStats bruteStats;
    const image::Image brute =
        ClRenderer(SharedContext(), scene, Quiet(Accel::kBrute)).Render(bruteStats);
    const Accel accel = GetParam().accel;
    RenderStats stats;
    ClRenderer renderer(SharedContext(), scene, Quiet(accel));
    renderer.UseProgram(BuildFrameProgram(SharedContext(), Quiet(accel)));
    const image::Image img = renderer.Render(stats);
    const image::ImageComparison same = image::Compare(img, brute);
    EXPECT_EQ(same.idMismatchPixels, 0u);
    EXPECT_EQ(same.maxAbsError, 0.0);
}

// Every query but brute force, the oracle (whose own program the next test uses).
std::vector<QueryCase> QueriesButBrute() {
    std::vector<QueryCase> out;
    for (const auto& [name, accel] : kAccels) {
        if (accel != Accel::kBrute) out.push_back({name, accel});
    }
    return out;
}

INSTANTIATE_TEST_SUITE_P(Queries, FrameProgramOfQuery, ::testing::ValuesIn(QueriesButBrute()),
                         [](const ::testing::TestParamInfo<QueryCase>& info) {
                             return std::string(info.param.name);
                         });

TEST(FrameProgram, EveryKernelStyleRendersBruteForcesImageFromItsOwnProgram) {
    // Each style's frame program holds only the classified kernel files it may launch: a kernel
    // missing from it would fail the render.
    const scene::Scene scene = SmallCornell();
    RenderStats bruteStats;
    const image::Image brute =
        ClRenderer(SharedContext(), scene, Quiet(Accel::kBrute)).Render(bruteStats);
    for (const auto& [name, style] : kKernelStyles) {
        RenderOptions options = Quiet(Accel::kClassify);
        options.kernel = style;
        RenderStats stats;
        ClRenderer renderer(SharedContext(), scene, options);
        renderer.UseProgram(BuildFrameProgram(SharedContext(), options));
        const image::ImageComparison same = image::Compare(renderer.Render(stats), brute);
        EXPECT_EQ(same.idMismatchPixels, 0u) << name;
        EXPECT_EQ(same.maxAbsError, 0.0) << name;
    }
}

TEST(FrameProgram, EveryQueryRendersBruteForcesImageFromTheSharedProgram) {
    // A renderer given no program builds the shared one: every query's kernels in one program.
    const scene::Scene scene = SmallCornell();
    RenderStats bruteStats;
    ClRenderer bruteRenderer(SharedContext(), scene, Quiet(Accel::kBrute));
    bruteRenderer.UseProgram(BuildFrameProgram(SharedContext(), Quiet(Accel::kBrute)));
    const image::Image brute = bruteRenderer.Render(bruteStats);
    for (const auto& [name, accel] : kAccels) {
        if (accel == Accel::kBrute) continue;
        RenderStats stats;
        const image::Image img = ClRenderer(SharedContext(), scene, Quiet(accel)).Render(stats);
        const image::ImageComparison same = image::Compare(img, brute);
        EXPECT_EQ(same.idMismatchPixels, 0u) << name;
        EXPECT_EQ(same.maxAbsError, 0.0) << name;
    }
}

TEST(FrameProgram, ARendererRefusesAProgramBuiltForOtherOptions) {
    const scene::Scene scene = SmallCornell();
    ClRenderer renderer(SharedContext(), scene, Quiet(Accel::kAuto));
    FrameProgram other;
    other.queryFiles = FrameQueryFiles(SharedContext(), Quiet(Accel::kBvh));
    other.buildOptions = FrameBuildOptions(Quiet(Accel::kAuto));
    EXPECT_THROW(renderer.UseProgram(other), std::invalid_argument);
    RenderOptions polar = Quiet(Accel::kAuto);
    polar.rayEncoding = RayEncoding::kPolar16;
    other.queryFiles = FrameQueryFiles(SharedContext(), Quiet(Accel::kAuto));
    other.buildOptions = FrameBuildOptions(polar);
    EXPECT_THROW(renderer.UseProgram(other), std::invalid_argument);
    other.buildOptions = FrameBuildOptions(Quiet(Accel::kAuto));
    EXPECT_NO_THROW(renderer.UseProgram(other));
}

TEST(FrameProgram, ARendererTakesTheSharedProgramOfItsBuildOptionsWhateverItsQuery) {
    const scene::Scene scene = SmallCornell();
    FrameProgram shared;  // every query's kernels: no accel
    shared.buildOptions = FrameBuildOptions(Quiet(Accel::kAuto));
    FrameProgram polar = shared;
    RenderOptions polarOptions = Quiet(Accel::kAuto);
    polarOptions.rayEncoding = RayEncoding::kPolar16;
    polar.buildOptions = FrameBuildOptions(polarOptions);
    for (const auto& [name, accel] : kAccels) {
        ClRenderer renderer(SharedContext(), scene, Quiet(accel));
        EXPECT_NO_THROW(renderer.UseProgram(shared)) << name;
        EXPECT_THROW(renderer.UseProgram(polar), std::invalid_argument) << name;
    }
}

}  // namespace
}  // namespace rayclass::render
