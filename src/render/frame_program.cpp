#include "rayclass/render/frame_program.h"

#include <chrono>
#include <vector>

#include "rayclass/classify/params.h"
#include "rayclass/render/classified_query.h"
#include "rayclass/render/launch.h"

namespace rayclass::render {

namespace {

// The kernel files of `accel`'s query (the classified query's: those of `classified`), in
// BuildRenderProgram's order.
std::vector<std::string> AccelFiles(Accel accel, const std::vector<std::string>& classified) {
    std::vector<std::string> out = classified;
    switch (accel) {
        case Accel::kClassify:
            return out;
        case Accel::kBvh:
            return {"bvh.cl"};
        case Accel::kAuto:
            out.push_back("bvh.cl");
            return out;
        case Accel::kBrute:
            return {"brute.cl"};
        case Accel::kKdTree:
            return {"kdtree.cl"};
        case Accel::kGrid:
            return {"grid.cl"};
        case Accel::kCones:
            return {"cones.cl"};
    }
    return {};
}

double SecondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

std::vector<std::string> FrameQueryFiles(const clrt::Context& ctx, const RenderOptions& options) {
    classify::Params params;
    for (const classify::ParamSetting& setting : options.classifyParams) setting.ApplyTo(params);
    return AccelFiles(options.accel, ClassifiedKernelFiles(ctx, params, ClassifiedStyle(options)));
}

std::string FrameBuildOptions(const RenderOptions& options) {
    std::string out;
    for (const std::string& option :
         {std::string(options.triangleTest == TriangleTest::kWatertight ? "-DRC_WATERTIGHT=1" : ""),
          std::string(options.rayEncoding == RayEncoding::kPolar16 ? "-DRC_POLAR16" : ""),
          options.buildOptions}) {
        if (option.empty()) continue;
        out += (out.empty() ? "" : " ") + option;
    }
    return out;
}

namespace {

// The program of the query kernels in `queryFiles`, or of every query's (none), and what it took.
FrameProgram Build(const clrt::Context& ctx, const RenderOptions& options,
                   std::vector<std::string> queryFiles) {
    const auto t0 = std::chrono::steady_clock::now();
    FrameProgram out;
    out.queryFiles = std::move(queryFiles);
    out.buildOptions = FrameBuildOptions(options);
    out.program = out.queryFiles.empty()
                      ? BuildRenderProgram(ctx, out.buildOptions, &out.fromCache)
                      : BuildProgramFiles(ctx, RenderProgramFiles(out.queryFiles), out.buildOptions,
                                          &out.fromCache);
    out.seconds = SecondsSince(t0);
    return out;
}

}  // namespace

FrameProgram BuildFrameProgram(const clrt::Context& ctx, const RenderOptions& options) {
    return Build(ctx, options, FrameQueryFiles(ctx, options));
}

FrameProgram BuildSharedFrameProgram(const clrt::Context& ctx, const RenderOptions& options) {
    return Build(ctx, options, {});
}

bool ServesFrame(const clrt::Context& ctx, const FrameProgram& program,
                 const RenderOptions& options) {
    return (program.queryFiles.empty() || program.queryFiles == FrameQueryFiles(ctx, options)) &&
           program.buildOptions == FrameBuildOptions(options);
}

}  // namespace rayclass::render
