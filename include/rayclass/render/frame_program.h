// The program a frame's kernels come from. PoCL reads a program's whole bitcode whenever it loads
// one, from its binary too, so a render's start-up pays for every kernel in it: a frame's program
// holds ray generation, shading and compaction, and the kernels of the options' ray query only
// (BuildRenderProgram, launch.h, builds every kernel, for the tests and benchmarks).
#pragma once

#include <string>

#include "rayclass/clrt/context.h"
#include "rayclass/render/options.h"

namespace rayclass::render {

struct FrameProgram {
    cl::Program program;
    Accel accel = Accel::kAuto;  // the query whose kernels it holds
    std::string buildOptions;    // the OpenCL build options it was built with
    bool fromCache = false;      // its binary came from the program cache
    double seconds = 0;          // what building or loading it took
};

// The OpenCL build options of a frame with `options` (triangle test, ray encoding, extra ones).
std::string FrameBuildOptions(const RenderOptions& options);

// The program a frame with `options` launches its kernels from.
FrameProgram BuildFrameProgram(const clrt::Context& ctx, const RenderOptions& options);

// True when `program` holds the kernels a frame with `options` launches, built as it needs them.
bool ServesFrame(const FrameProgram& program, const RenderOptions& options);

}  // namespace rayclass::render
