#include "rayclass/render/frame_program.h"

#include <chrono>
#include <vector>

#include "rayclass/render/launch.h"

namespace rayclass::render {

namespace {

// The kernel files of `accel`'s query, in BuildRenderProgram's order.
std::vector<std::string> QueryFiles(Accel accel) {
    switch (accel) {
        case Accel::kClassify:
            return {"classified.cl"};
        case Accel::kBvh:
            return {"bvh.cl"};
        case Accel::kAuto:
            return {"classified.cl", "bvh.cl"};
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

// The program of `accel`'s query kernels, or of every query's (none), and what it took.
FrameProgram Build(const clrt::Context& ctx, const RenderOptions& options,
                   std::optional<Accel> accel) {
    const auto t0 = std::chrono::steady_clock::now();
    FrameProgram out;
    out.accel = accel;
    out.buildOptions = FrameBuildOptions(options);
    out.program = accel ? BuildProgramFiles(ctx, RenderProgramFiles(QueryFiles(*accel)),
                                            out.buildOptions, &out.fromCache)
                        : BuildRenderProgram(ctx, out.buildOptions, &out.fromCache);
    out.seconds = SecondsSince(t0);
    return out;
}

}  // namespace

FrameProgram BuildFrameProgram(const clrt::Context& ctx, const RenderOptions& options) {
    return Build(ctx, options, options.accel);
}

FrameProgram BuildSharedFrameProgram(const clrt::Context& ctx, const RenderOptions& options) {
    return Build(ctx, options, std::nullopt);
}

bool ServesFrame(const FrameProgram& program, const RenderOptions& options) {
    return (!program.accel || *program.accel == options.accel) &&
           program.buildOptions == FrameBuildOptions(options);
}

}  // namespace rayclass::render
