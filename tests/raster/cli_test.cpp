// The command line: --eye-rays and --hull, and the fallback to the kernel when no OpenGL
// context can be made (forced by pointing glvnd at no EGL vendor).
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "raster_support.h"

namespace rayclass::raster {
namespace {

using namespace testing_support;

struct CliRun {
    int status;
    std::string err;
};

CliRun RunRayclass(const std::string& env, const std::string& args) {
    const auto dir = std::filesystem::temp_directory_path() / ("rc_raster_cli_" + std::to_string(getpid()));
    std::filesystem::create_directories(dir);
    const std::string errFile = (dir / "err.txt").string();
    const std::string cmd = env + " '" + std::string(std::getenv("RAYCLASS_BINARY")) + "' " + args +
                            " 2>'" + errFile + "' >/dev/null";
    const int rc = std::system(cmd.c_str());
    std::ifstream in(errFile);
    std::stringstream ss;
    ss << in.rdbuf();
    return {WIFEXITED(rc) ? WEXITSTATUS(rc) : -1, ss.str()};
}

std::string Scene() { return (SceneDir() / "tests/spheres.json").string(); }

std::string Out(const char* name) {
    return (std::filesystem::temp_directory_path() / ("rc_raster_cli_" + std::to_string(getpid())) / name).string();
}

TEST(RasterCli, DefaultUsesRasterWhenGlWorks) {
    RC_REQUIRE_GL();
    const std::string stats = Out("stats.json");
    const CliRun r = RunRayclass("", "render '" + Scene() + "' -o '" + Out("a.png") +
                                      "' --width 40 --height 30 -q --stats '" + stats + "'");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(r.err, "");
    std::ifstream in(stats);
    std::stringstream ss;
    ss << in.rdbuf();
    EXPECT_NE(ss.str().find("\"eye_rays\": \"raster\""), std::string::npos) << ss.str();
}

TEST(RasterCli, FallsBackToKernelWithOneNotice) {
    const CliRun r = RunRayclass("__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json",
                              "render '" + Scene() + "' -o '" + Out("b.png") +
                                  "' --width 40 --height 30 -q");
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_NE(r.err.find("no OpenGL context, eye rays by kernel"), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

TEST(RasterCli, ExplicitRasterWithoutGlFails) {
    const CliRun r = RunRayclass("__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json",
                              "render '" + Scene() + "' -o '" + Out("c.png") +
                                  "' --width 40 --height 30 -q --eye-rays raster");
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_NE(r.err.find("OpenGL context"), std::string::npos) << r.err;
}

TEST(RasterCli, BadOptionsAreUsageErrors) {
    EXPECT_EQ(RunRayclass("", "render '" + Scene() + "' -o '" + Out("d.png") + "' --hull cone").status, 2);
    EXPECT_EQ(RunRayclass("", "render '" + Scene() + "' -o '" + Out("d.png") + "' --eye-rays gpu").status, 2);
}

TEST(RasterCli, EveryHullRenders) {
    RC_REQUIRE_GL();
    for (const char* hull : {"sphere", "box", "billboard", "auto"}) {
        const CliRun r = RunRayclass("", "render '" + Scene() + "' -o '" + Out("e.png") +
                                          "' --width 40 --height 30 -q --eye-rays raster --hull " + hull);
        EXPECT_EQ(r.status, 0) << hull << ": " << r.err;
    }
}

}  // namespace
}  // namespace rayclass::raster
