// The OpenCL runtime layer: device selection and its error messages, error names, program builds
// from the embedded kernel sources and what a failed build reports.
#include "rayclass/clrt/context.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sched.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "clrt/device.h"
#include "rayclass/core/error.h"

namespace rayclass::clrt {
namespace {

using ::testing::HasSubstr;
using testing::kProbeOptions;
using testing::TestContext;

// PinPoclWorkers' inputs for one test: POCL_AFFINITY unset, POCL_MAX_PTHREAD_COUNT and the
// process's cores as given; the environment and the cores as they were afterwards.
class PinInputs {
  public:
    PinInputs(const char* workers, std::vector<int> cores) {
        for (const char* name : {"POCL_AFFINITY", "POCL_MAX_PTHREAD_COUNT"}) {
            if (const char* v = std::getenv(name)) saved_[name] = v;
            unsetenv(name);
        }
        if (workers != nullptr) setenv("POCL_MAX_PTHREAD_COUNT", workers, 1);
        sched_getaffinity(0, sizeof(cores_), &cores_);
        cpu_set_t set;
        CPU_ZERO(&set);
        for (int c : cores) CPU_SET(c, &set);
        restricted_ = sched_setaffinity(0, sizeof(set), &set) == 0;
    }
    ~PinInputs() {
        sched_setaffinity(0, sizeof(cores_), &cores_);
        for (const char* name : {"POCL_AFFINITY", "POCL_MAX_PTHREAD_COUNT"}) {
            unsetenv(name);
            if (saved_.count(name)) setenv(name, saved_[name].c_str(), 1);
        }
    }
    bool Applied() const { return restricted_; }
    static std::optional<std::string> Affinity() {
        const char* v = std::getenv("POCL_AFFINITY");
        return v ? std::optional<std::string>(v) : std::nullopt;
    }

  private:
    std::map<std::string, std::string> saved_;
    cpu_set_t cores_;
    bool restricted_ = false;
};

TEST(PinPoclWorkers, PinsTwoWorkersOnTheProcesssFirstTwoCores) {
    if (sysconf(_SC_NPROCESSORS_ONLN) < 2) GTEST_SKIP() << "needs two cores";
    PinInputs in("2", {0, 1});
    if (!in.Applied()) GTEST_SKIP() << "cores 0 and 1 are not this process's";
    PinPoclWorkers();
    EXPECT_EQ(PinInputs::Affinity(), "1");
}

TEST(PinPoclWorkers, LeavesWorkersFreeWhereACoreIsNotTheProcesss) {
    if (sysconf(_SC_NPROCESSORS_ONLN) < 2) GTEST_SKIP() << "needs two cores";
    PinInputs in("2", {1});
    if (!in.Applied()) GTEST_SKIP() << "core 1 is not this process's";
    PinPoclWorkers();
    EXPECT_EQ(PinInputs::Affinity(), std::nullopt);
}

TEST(PinPoclWorkers, LeavesOneWorkerAndTheCallersSettingAlone) {
    if (sysconf(_SC_NPROCESSORS_ONLN) < 2) GTEST_SKIP() << "needs two cores";
    {
        PinInputs in("1", {0, 1});
        PinPoclWorkers();
        EXPECT_EQ(PinInputs::Affinity(), std::nullopt);
    }
    PinInputs in("2", {0, 1});
    setenv("POCL_AFFINITY", "0", 1);
    PinPoclWorkers();
    EXPECT_EQ(PinInputs::Affinity(), "0");
}

// The message of the rayclass::Error that `f` throws ("" if it throws none).
template <typename F>
std::string ErrorOf(F&& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

// What BuildProgram throws for `files` and `options`; fails the test if it does not throw.
ClError BuildError(const std::vector<std::string>& files, const std::string& options) {
    try {
        TestContext().BuildProgram(files, options);
    } catch (const ClError& e) {
        return e;
    }
    ADD_FAILURE() << "building with '" << options << "' did not throw";
    return ClError("", 0, "");
}

// The text of cl/<name> in the source tree.
std::string SourceFile(const std::string& name) {
    const char* root = std::getenv("RAYCLASS_SOURCE_DIR");
    std::ifstream in(std::string(root ? root : ".") + "/cl/" + name);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

size_t Count(const std::string& text, const std::string& what) {
    size_t n = 0;
    for (size_t pos = text.find(what); pos != std::string::npos; pos = text.find(what, pos + 1)) {
        ++n;
    }
    return n;
}

TEST(Context, TestDeviceIsTheOneAskedForAndRunsKernels) {
    Context& ctx = TestContext();
    const std::string spec = TestDeviceSpec();
    if (spec == "cpu") {
        EXPECT_EQ(ctx.info().type, "cpu");
        EXPECT_THAT(ctx.info().platform, HasSubstr("Portable Computing Language"));
    } else if (spec == "gpu") {
        EXPECT_EQ(ctx.info().type, "gpu");
    } else if (spec != "auto") {
        EXPECT_EQ(std::to_string(ctx.info().index), spec);
    }
    EXPECT_FALSE(ctx.info().name.empty());
    EXPECT_GT(ctx.info().computeUnits, 0u);
    // The device it chose is the one ListDevices reports at its index.
    const auto devices = ListDevices();
    ASSERT_LT(size_t(ctx.info().index), devices.size());
    EXPECT_EQ(devices[size_t(ctx.info().index)].name, ctx.info().name);
    // The queue runs a kernel: the layout probe writes a count first.
    const cl::Program program = ctx.BuildProgram({"layout_probe.cl"}, kProbeOptions);
    cl::Kernel kernel(program, "rc_layout_probe");
    cl::Buffer out(ctx.context(), CL_MEM_WRITE_ONLY, 1024 * sizeof(uint32_t));
    kernel.setArg(0, out);
    ctx.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(1));
    EXPECT_GT(testing::Download<uint32_t>(out, 1)[0], 0u);
}

TEST(Context, ByIndexSelectsThatDevice) {
    const auto devices = ListDevices();
    ASSERT_FALSE(devices.empty());
    for (const auto& d : devices) {
        const Context ctx(std::to_string(d.index));
        EXPECT_EQ(ctx.info().index, d.index);
        EXPECT_EQ(ctx.info().name, d.name);
    }
}

TEST(Context, IndexOutOfRangeNamesTheDeviceCount) {
    const size_t n = ListDevices().size();
    const std::string count = std::to_string(n);
    EXPECT_EQ(
        ErrorOf([&] { Context ctx(count); }),
        "device index " + count + " out of range (" + count + " devices; see 'rayclass devices')");
    if (n <= 7) {
        EXPECT_EQ(ErrorOf([] { Context ctx("7"); }),
                  "device index 7 out of range (" + count + " devices; see 'rayclass devices')");
    }
}

TEST(Context, MalformedSpecIsRejected) {
    for (const std::string spec : {"banana", "-1", "1x", "CPU", "0.5", "0 1"}) {
        EXPECT_EQ(ErrorOf([&] { Context ctx(spec); }),
                  "--device must be cpu, gpu, auto or a device index, not '" + spec + "'")
            << spec;
    }
}

TEST(Context, MissingDeviceTypeIsReported) {
    bool hasGpu = false;
    for (const auto& d : ListDevices()) hasGpu = hasGpu || d.type == "gpu";
    if (hasGpu) GTEST_SKIP() << "this machine has an OpenCL GPU";
    EXPECT_EQ(ErrorOf([] { Context ctx("gpu"); }),
              "no OpenCL gpu device found (see 'rayclass devices')");
    // auto falls back to the first CPU.
    EXPECT_EQ(Context("auto").info().type, "cpu");
    EXPECT_EQ(Context("").info().type, "cpu");
}

TEST(ErrorName, NamesStatusCodes) {
    EXPECT_STREQ(ErrorName(CL_INVALID_VALUE), "CL_INVALID_VALUE");
    EXPECT_STREQ(ErrorName(CL_SUCCESS), "CL_SUCCESS");
    EXPECT_STREQ(ErrorName(CL_BUILD_PROGRAM_FAILURE), "CL_BUILD_PROGRAM_FAILURE");
    EXPECT_STREQ(ErrorName(CL_OUT_OF_RESOURCES), "CL_OUT_OF_RESOURCES");
    EXPECT_STREQ(ErrorName(-12345), "unknown OpenCL error");
}

TEST(ClError, WhatNamesTheCallTheErrorAndItsCode) {
    const ClError e("clEnqueueNDRangeKernel", CL_INVALID_VALUE, ErrorName(CL_INVALID_VALUE));
    EXPECT_STREQ(e.what(), "clEnqueueNDRangeKernel failed with CL_INVALID_VALUE (-30)");
    EXPECT_EQ(e.code(), CL_INVALID_VALUE);
}

TEST(BuildProgram, CompileErrorCarriesTheBuildLogNamingTheKernelFile) {
    // An empty RC_LOCAL_SIZE leaves reqd_work_group_size( , 1, 1) in brute.cl.
    const ClError e = BuildError({"brute.cl"}, "-cl-std=CL1.2 -DRC_LOCAL_SIZE=");
    EXPECT_EQ(e.code(), CL_BUILD_PROGRAM_FAILURE);
    const std::string what = e.what();
    EXPECT_THAT(what, HasSubstr("building OpenCL program (brute.cl) with options '-cl-std=CL1.2 "
                                "-DRC_LOCAL_SIZE=' failed with CL_BUILD_PROGRAM_FAILURE (-11)\n"
                                "build log:\n"));
    // The log points into brute.cl itself (the #line directives), at both kernels' attributes,
    // not at lines of the assembled source. The lines are read from the file, so editing it
    // does not break the test.
    const char* source = std::getenv("RAYCLASS_SOURCE_DIR");
    ASSERT_NE(source, nullptr);
    std::ifstream file(std::string(source) + "/cl/brute.cl");
    std::vector<int> attributeLines;
    std::string line;
    for (int n = 1; std::getline(file, line); ++n) {
        if (line.find("reqd_work_group_size(RC_LOCAL_SIZE") != std::string::npos) {
            attributeLines.push_back(n);
        }
    }
    ASSERT_EQ(attributeLines.size(), 2u);
    for (int n : attributeLines) {
        EXPECT_THAT(what, HasSubstr("brute.cl:" + std::to_string(n) + ":"));
    }
}

TEST(BuildProgram, UnknownBuildOptionIsReported) {
    const ClError e = BuildError({"brute.cl"}, "-DRC_LOCAL_SIZE=64 -cl-no-such-option");
    const std::string what = e.what();
    EXPECT_TRUE(e.code() == CL_INVALID_BUILD_OPTIONS || e.code() == CL_BUILD_PROGRAM_FAILURE)
        << what;
    EXPECT_THAT(what, HasSubstr("building OpenCL program (brute.cl) with options "
                                "'-DRC_LOCAL_SIZE=64 -cl-no-such-option' failed with "));
    EXPECT_THAT(what, HasSubstr(ErrorName(e.code())));
    // PoCL rejects it before compiling (CL_INVALID_BUILD_OPTIONS) and names it in the log.
    const size_t log = what.find("\nbuild log:\n");
    ASSERT_NE(log, std::string::npos) << what;
    EXPECT_THAT(what.substr(log), HasSubstr("-cl-no-such-option")) << what;
}

TEST(BuildProgram, FileThatIsNotEmbeddedIsReported) {
    EXPECT_EQ(ErrorOf([] { TestContext().BuildProgram({"nope.cl"}, kProbeOptions); }),
              "kernel source 'nope.cl' is not embedded");
}

TEST(AssembleProgramSource, ResolvesEachIncludeOnce) {
    // brute.cl includes rc_types.h and intersect.cl, which includes rc_types.h again.
    const std::string source = AssembleProgramSource({"camera.cl", "shade.cl", "brute.cl"});
    EXPECT_EQ(Count(source, "#define RAYCLASS_RC_TYPES_H"), 1u);
    EXPECT_EQ(Count(source, "inline int rc_intersect_triangle("), 1u);
    EXPECT_EQ(Count(source, "#include \""), 0u);
    EXPECT_EQ(Count(source, "#line 1 \"shared/rc_types.h\"\n"), 1u);
    EXPECT_EQ(Count(source, "#line 1 \"intersect.cl\"\n"), 1u);
    // Each file starts with its own #line 1, and resumes after each include with the next line.
    EXPECT_EQ(source.rfind("#line 1 \"camera.cl\"\n", 0), 0u);
    EXPECT_THAT(source, HasSubstr("#line 4 \"brute.cl\"\n"));  // after rc_types.h (skipped)
    EXPECT_THAT(source, HasSubstr("#line 5 \"brute.cl\"\n"));  // after intersect.cl (skipped)
}

TEST(AssembleProgramSource, ResolvesAnIncFileAtEachInclude) {
    // bvh.cl includes bvh_packet.inc.cl twice, once per lane width; accel_common.cl includes
    // bvh.cl again, which is skipped with its includes.
    const std::string source = AssembleProgramSource({"bvh.cl", "accel_common.cl"});
    EXPECT_EQ(Count(source, "#line 1 \"bvh_packet.inc.cl\"\n"), 2u);
    EXPECT_EQ(Count(source, "#line 1 \"bvh.cl\"\n"), 1u);
    EXPECT_EQ(Count(source, "#include \""), 0u);
}

// Every line of the assembled source is the line of the file that the #line directives say, and
// every line of every file is there (except its #include lines), so build logs point right.
TEST(AssembleProgramSource, LineDirectivesMapEveryLineToItsFile) {
    const std::vector<std::string> files = {"camera.cl", "intersect.cl", "shade.cl", "brute.cl"};
    const std::string source = AssembleProgramSource(files);
    static const std::regex kLine(R"re(^#line (\d+) "([^"]+)"$)re");
    std::map<std::string, std::vector<std::string>> lines;  // file -> its lines, 0-based
    std::map<std::string, std::vector<bool>> seen;
    auto fileLines = [&](const std::string& name) -> std::vector<std::string>& {
        auto it = lines.find(name);
        if (it != lines.end()) return it->second;
        std::vector<std::string> text;
        std::istringstream in(SourceFile(name));
        for (std::string l; std::getline(in, l);) text.push_back(l);
        seen[name].assign(text.size(), false);
        return lines[name] = text;
    };
    std::string file;
    size_t next = 0;  // 1-based line number of the next source line
    std::istringstream in(source);
    size_t checked = 0;
    for (std::string line; std::getline(in, line);) {
        std::smatch m;
        if (std::regex_match(line, m, kLine)) {
            file = m[2];
            next = std::stoul(m[1]);
            continue;
        }
        ASSERT_FALSE(file.empty()) << "source before the first #line: " << line;
        const auto& text = fileLines(file);
        ASSERT_GE(next, 1u);
        ASSERT_LE(next, text.size()) << file;
        EXPECT_EQ(line, text[next - 1]) << file << ":" << next;
        seen[file][next - 1] = true;
        ++next;
        ++checked;
    }
    EXPECT_GT(checked, 400u);
    for (const std::string name :
         {"camera.cl", "intersect.cl", "shade.cl", "brute.cl", "shared/rc_types.h"}) {
        ASSERT_TRUE(seen.count(name)) << name;
        const auto& text = lines[name];
        for (size_t i = 0; i < text.size(); ++i) {
            if (text[i].find("#include") == std::string::npos) {
                EXPECT_TRUE(seen[name][i]) << name << ":" << i + 1 << " missing";
            }
        }
    }
}

}  // namespace
}  // namespace rayclass::clrt
