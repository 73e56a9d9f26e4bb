// The command line: --eye-rays (auto's choice between raster and kernel), --hull, --depth-bits
// and --depth-scale, and the fallback to the kernel when no OpenGL context can be made (forced
// by pointing glvnd at no EGL vendor).
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "raster_support.h"

namespace rayclass::raster {
namespace {

using namespace testing_support;

struct CliRun {
    int status;
    std::string err;
};

std::string ReadFile(const std::string& path) {
    std::ifstream in(path);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
}

// This test process's scratch directory, removed when the process ends (each test runs in a
// process of its own under CTest: the directories piled up in /tmp before).
const std::filesystem::path& ScratchDir() {
    static const struct Dir {
        std::filesystem::path path =
            std::filesystem::temp_directory_path() / ("rc_raster_cli_" + std::to_string(getpid()));
        Dir() { std::filesystem::create_directories(path); }
        ~Dir() {
            std::error_code ignored;
            std::filesystem::remove_all(path, ignored);
        }
    } dir;
    return dir.path;
}

CliRun RunRayclass(const std::string& env, const std::string& args) {
    const std::string errFile = (ScratchDir() / "err.txt").string();
    const std::string cmd = env + " '" + std::string(std::getenv("RAYCLASS_BINARY")) + "' " + args +
                            " 2>'" + errFile + "' >/dev/null";
    const int rc = std::system(cmd.c_str());
    return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, ReadFile(errFile)};
}

std::string Scene() { return (SceneDir() / "tests/spheres.json").string(); }

std::string Out(const char* name) { return (ScratchDir() / name).string(); }

// The stats' eye_rays and eye_rays_choice after rendering the test scene with `options`.
std::pair<std::string, std::string> EyeRaysOf(const std::string& options) {
    const std::string stats = Out("stats.json");
    const CliRun r =
        RunRayclass("", "render '" + Scene() + "' -o '" + Out("a.png") +
                            "' --width 40 --height 30 -q --stats '" + stats + "' " + options);
    EXPECT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err, "") << options;
    const nlohmann::json j = nlohmann::json::parse(ReadFile(stats));
    return {j.at("eye_rays").get<std::string>(), j.at("eye_rays_choice").get<std::string>()};
}

TEST(RasterCli, AutoTakesTheKernelOnSoftwareGlAndRasterOnHardware) {
    RC_REQUIRE_GL();
    const std::string renderer = gl->Renderer();
    using Choice = std::pair<std::string, std::string>;
    const auto expected =
        OnlySoftwareEglDevices()
            ? Choice{"kernel", "auto: kernel, software OpenGL only (EGL_MESA_device_software)"}
        : IsSoftwareRenderer(renderer)
            ? Choice{"kernel", "auto: kernel, software OpenGL (" + renderer + ")"}
            : Choice{"raster", "auto: raster on hardware OpenGL (" + renderer + ")"};
    EXPECT_EQ(EyeRaysOf(""), expected);
    EXPECT_EQ(EyeRaysOf("--eye-rays auto"), expected);
}

TEST(RasterCli, ExplicitChoicesAndRasterOptionsWin) {
    RC_REQUIRE_GL();
    using Choice = std::pair<std::string, std::string>;
    EXPECT_EQ(EyeRaysOf("--eye-rays raster"), (Choice{"raster", "--eye-rays raster"}));
    EXPECT_EQ(EyeRaysOf("--eye-rays kernel"), (Choice{"kernel", "--eye-rays kernel"}));
    // A raster experiment stays one on a software renderer.
    EXPECT_EQ(EyeRaysOf("--hull box"), (Choice{"raster", "auto: raster for --hull"}));
    EXPECT_EQ(EyeRaysOf("--depth-bits 32"), (Choice{"raster", "auto: raster for --depth-bits"}));
}

// Patch boxes are drawn like the other primitives: raster asked for is raster given.
TEST(RasterCli, PatchScenesTakeTheRasterPass) {
    RC_REQUIRE_GL();
    const std::string stats = Out("patch_stats.json");
    const CliRun r = RunRayclass(
        "", "render '" + (SceneDir() / "teapot.json").string() + "' -o '" + Out("t.png") +
                "' --width 32 --height 24 -q --eye-rays raster --stats '" + stats + "'");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err, "");
    const nlohmann::json j = nlohmann::json::parse(ReadFile(stats));
    EXPECT_EQ(j.at("eye_rays"), "raster");
    EXPECT_EQ(j.at("eye_rays_choice"), "--eye-rays raster");
}

// The shortcut must not hide a hardware renderer: where EGL lists software devices alone, the
// context is a software one.
TEST(RasterCli, OnlySoftwareEglDevicesMeansASoftwareContext) {
    RC_REQUIRE_GL();
    if (!OnlySoftwareEglDevices()) GTEST_SKIP() << "EGL lists a hardware device";
    EXPECT_TRUE(IsSoftwareRenderer(gl->Renderer())) << gl->Renderer();
}

TEST(RasterCli, SoftwareRenderersAreRecognised) {
    EXPECT_TRUE(IsSoftwareRenderer("llvmpipe (LLVM 15.0.6, 256 bits)"));
    EXPECT_TRUE(IsSoftwareRenderer("softpipe"));
    EXPECT_TRUE(IsSoftwareRenderer("Mesa X11 swrast"));
    EXPECT_FALSE(IsSoftwareRenderer("NVIDIA GeForce RTX 4090/PCIe/SSE2"));
    EXPECT_FALSE(IsSoftwareRenderer("AMD Radeon RX 7900 XTX (radeonsi, navi31, LLVM 15.0.7)"));
    EXPECT_FALSE(IsSoftwareRenderer("Mesa Intel(R) Arc(tm) A770 Graphics (DG2)"));
}

TEST(RasterCli, FallsBackToKernelWithOneNotice) {
    const CliRun r =
        RunRayclass("__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json",
                    "render '" + Scene() + "' -o '" + Out("b.png") + "' --width 40 --height 30 -q");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find("no OpenGL context, eye rays by kernel"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

TEST(RasterCli, RasterOptionsWithoutGlFail) {
    const CliRun r = RunRayclass(
        "__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json",
        "render '" + Scene() + "' -o '" + Out("c.png") + "' --width 40 --height 30 -q --hull box");
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.err.find("OpenGL context"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(Out("c.png")));
}

TEST(RasterCli, ExplicitRasterWithoutGlFails) {
    const CliRun r = RunRayclass("__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json",
                                 "render '" + Scene() + "' -o '" + Out("c.png") +
                                     "' --width 40 --height 30 -q --eye-rays raster");
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.err.find("OpenGL context"), std::string::npos) << r.err;
}

TEST(RasterCli, BadOptionsAreUsageErrors) {
    EXPECT_EQ(
        RunRayclass("", "render '" + Scene() + "' -o '" + Out("d.png") + "' --hull cone").status,
        2);
    const CliRun gpu =
        RunRayclass("", "render '" + Scene() + "' -o '" + Out("d.png") + "' --eye-rays gpu");
    EXPECT_EQ(gpu.status, 2);
    EXPECT_EQ(gpu.err, "rayclass render: --eye-rays expects auto, raster or kernel, not 'gpu'\n");
}

TEST(RasterCli, UnsafeDepthSettingsGetOneWarningLine) {
    RC_REQUIRE_GL();
    const CliRun r = RunRayclass("", "render '" + Scene() + "' -o '" + Out("f.png") +
                                         "' --width 40 --height 30 -q --depth-bits 16");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err,
              "rayclass: warning: 16-bit depth steps are 0.000488 world units at depth "
              "scale 2^-5 (over 2^-20 of the scene's depth range 21.7): surfaces closer "
              "than a step may swap ids\n");
    // The automatic scale given explicitly is as safe as the default.
    const CliRun safe = RunRayclass("", "render '" + Scene() + "' -o '" + Out("g.png") +
                                            "' --width 40 --height 30 -q --depth-bits 32 "
                                            "--depth-scale 0.03125");
    ASSERT_EQ(safe.status, 0) << safe.err;
    EXPECT_EQ(safe.err, "");
}

TEST(RasterCli, BadDepthOptionsAreUsageErrors) {
    const std::string base = "render '" + Scene() + "' -o '" + Out("h.png") + "' ";
    const std::pair<const char*, const char*> cases[] = {
        {"--depth-bits 8", "rayclass render: --depth-bits must be 16, 24 or 32, not '8'\n"},
        {"--depth-bits 32.0", "rayclass render: --depth-bits must be 16, 24 or 32, not '32.0'\n"},
        {"--depth-scale 0",
         "rayclass render: --depth-scale expects a number in [1e-30, 1e+30], not '0'\n"},
        {"--depth-scale -1",
         "rayclass render: --depth-scale expects a number in [1e-30, 1e+30], not '-1'\n"},
        {"--depth-scale inf",
         "rayclass render: --depth-scale expects a number in [1e-30, 1e+30], not 'inf'\n"},
        {"--depth-scale", "rayclass render: --depth-scale needs a value\n"},
    };
    for (const auto& [args, message] : cases) {
        const CliRun r = RunRayclass("", base + args);
        EXPECT_EQ(r.status, 2) << args;
        EXPECT_EQ(r.err, message) << args;
    }
}

TEST(RasterCli, RasterOptionsWithoutTheRasterPassAreUsageErrors) {
    const std::string base = "render '" + Scene() + "' -o '" + Out("i.png") + "' ";
    const std::pair<const char*, const char*> cases[] = {
        {"--eye-rays kernel --hull box",
         "rayclass render: --hull sets up the raster eye-ray pass, which --eye-rays kernel does "
         "not run\n"},
        {"--depth-bits 16 --reference --hull box",
         "rayclass render: --depth-bits sets up the raster eye-ray pass, which --reference does "
         "not run\n"},
        {"--depth-scale 0.5 --eye-rays kernel",
         "rayclass render: --depth-scale sets up the raster eye-ray pass, which --eye-rays "
         "kernel does not run\n"},
    };
    for (const auto& [args, message] : cases) {
        const CliRun r = RunRayclass("", base + args);
        EXPECT_EQ(r.status, 2) << args;
        EXPECT_EQ(r.err, message) << args;
        EXPECT_FALSE(std::filesystem::exists(Out("i.png"))) << args;
    }
}

// The raster pass traces exact eye directions, so it cannot answer polar16 eye rays: asking for
// it is a usage error, and auto takes the kernel (before looking for OpenGL at all).
TEST(RasterCli, Polar16DirectionsTakeKernelEyeRays) {
    const std::string base = "render '" + Scene() + "' -o '" + Out("p.png") + "' ";
    const std::pair<const char*, const char*> cases[] = {
        {"--ray-encoding polar16 --eye-rays raster",
         "rayclass render: --ray-encoding polar16 needs kernel eye rays: the raster pass "
         "(--eye-rays raster) traces exact eye directions\n"},
        {"--hull box --ray-encoding polar16",
         "rayclass render: --ray-encoding polar16 needs kernel eye rays: the raster pass "
         "(--hull) traces exact eye directions\n"},
    };
    for (const auto& [args, message] : cases) {
        const CliRun r = RunRayclass("", base + args);
        EXPECT_EQ(r.status, 2) << args;
        EXPECT_EQ(r.err, message) << args;
        EXPECT_FALSE(std::filesystem::exists(Out("p.png"))) << args;
    }
    using Choice = std::pair<std::string, std::string>;
    const Choice kernel{"kernel", "auto: kernel for --ray-encoding polar16"};
    EXPECT_EQ(EyeRaysOf("--ray-encoding polar16"), kernel);
    EXPECT_EQ(EyeRaysOf("--ray-encoding polar16 --eye-rays auto"), kernel);
    EXPECT_EQ(EyeRaysOf("--ray-encoding polar16 --eye-rays kernel"),
              (Choice{"kernel", "--eye-rays kernel"}));
}

TEST(RasterCli, EveryHullRenders) {
    RC_REQUIRE_GL();
    for (const char* hull : {"sphere", "box", "billboard", "auto"}) {
        const CliRun r =
            RunRayclass("", "render '" + Scene() + "' -o '" + Out("e.png") +
                                "' --width 40 --height 30 -q --eye-rays raster --hull " + hull);
        EXPECT_EQ(r.status, 0) << hull << ": " << r.err;
    }
}

// PoCL and an OpenGL driver built on LLVM (llvmpipe here) share one libLLVM whose start is not
// thread-safe, and the device starts on a thread of its own: the OpenGL context must wait for it.
// The preloaded probe aborts when both start LLVM at once (a crash, rarely, before); drivers
// without LLVM never meet it, and auto on software OpenGL makes no context at all. ASan, in
// sanitizer builds, must then allow a library before its runtime.
TEST(RasterCli, TheOpenGlDriverStartsLlvmAfterTheDevice) {
    RC_REQUIRE_GL();
    const char* asan = std::getenv("ASAN_OPTIONS");
    const std::string env = std::string("LD_PRELOAD='") + RAYCLASS_LLVM_START_PROBE +
                            "' ASAN_OPTIONS='" + (asan ? asan : "") + ":verify_asan_link_order=0'";
    for (const char* eyeRays : {"raster", "auto --hull box", "auto"}) {
        const CliRun r = RunRayclass(env, "render '" + Scene() + "' -o '" + Out("l.png") +
                                              "' --width 40 --height 30 -q --eye-rays " + eyeRays);
        EXPECT_EQ(r.status, 0) << eyeRays;
        EXPECT_EQ(r.err, "") << eyeRays;
    }
}

}  // namespace
}  // namespace rayclass::raster
