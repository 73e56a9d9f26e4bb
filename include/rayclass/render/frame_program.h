// The program a frame's kernels come from: ray generation, shading and compaction, and ray query
// kernels. Two kinds, with a cost each:
// - BuildFrameProgram's holds the options' query's kernels only (of the classified query, those
//   of the kernel styles the frame may launch). PoCL reads a program's whole
//   bitcode whenever it loads one, from its binary too, so a render's start-up pays for every
//   kernel in it; but each --accel is a program cache entry of its own, compiled from source once
//   per accel and build options, and PoCL compiles every kernel it launches once per program
//   (POCL_CACHE_DIR), shading's too. For a command that renders with one --accel: rayclass render.
// - BuildSharedFrameProgram's holds every query's kernels (BuildRenderProgram's, launch.h): one
//   cache entry that frames of every --accel with the same build options share, so empty caches
//   compile it and its kernels once. What a ClRenderer given no program builds: the tests and
//   benchmarks.
#pragma once

#include <string>
#include <vector>

#include "rayclass/clrt/context.h"
#include "rayclass/render/options.h"

namespace rayclass::render {

struct FrameProgram {
    cl::Program program;
    std::vector<std::string> queryFiles;  // the query kernel files it holds; none: every query's
    std::string buildOptions;             // the OpenCL build options it was built with
    bool fromCache = false;               // its binary came from the program cache
    double seconds = 0;                   // what building or loading it took
};

// The query kernel files (cl/*.cl) of a frame with `options` on ctx's device: its --accel's, and
// of the classified query's only those of the kernel styles it may launch.
std::vector<std::string> FrameQueryFiles(const clrt::Context& ctx, const RenderOptions& options);

// The OpenCL build options of a frame with `options` (triangle test, ray encoding, extra ones).
std::string FrameBuildOptions(const RenderOptions& options);

// The program a frame with `options` launches its kernels from, with its query's kernels only.
FrameProgram BuildFrameProgram(const clrt::Context& ctx, const RenderOptions& options);

// The program frames with `options`' build options launch their kernels from, whatever their
// --accel: every query's kernels.
FrameProgram BuildSharedFrameProgram(const clrt::Context& ctx, const RenderOptions& options);

// True when `program` holds the kernels a frame with `options` launches, built as it needs them.
bool ServesFrame(const clrt::Context& ctx, const FrameProgram& program,
                 const RenderOptions& options);

}  // namespace rayclass::render
