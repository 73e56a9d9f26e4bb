// Which path finds the eye rays' first hits: the raster pass or the kernels' ray query. This is
// the render layer's policy; it sits in the raster layer because it needs OpenGL to decide, and
// rc_raster, above rc_render, is the lowest library that sees both the renderer's EyeHitSource
// and the GlContext.
#pragma once

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <memory>
#include <string>

#include "rayclass/raster/raster_pass.h"
#include "rayclass/render/eye_hits.h"
#include "rayclass/render/options.h"
#include "rayclass/scene/scene.h"

namespace rayclass::raster {

enum class EyeRayPath : uint8_t { kAuto, kRaster, kKernel };
inline constexpr render::Named<EyeRayPath> kEyeRayPaths[] = {
    {"auto", EyeRayPath::kAuto}, {"raster", EyeRayPath::kRaster}, {"kernel", EyeRayPath::kKernel}};

struct EyeRayRequest {
    EyeRayPath path = EyeRayPath::kAuto;
    RasterOptions raster;      // the raster pass's settings, where it runs
    std::string rasterOption;  // the first option given that only the raster pass reads

    // An explicit raster path, or a raster option: a raster experiment, which auto must not
    // answer by kernel.
    bool RasterAsked() const { return path == EyeRayPath::kRaster || !rasterOption.empty(); }
};

struct EyeRays {
    std::unique_ptr<render::EyeHitSource> hits;  // null: the ray query answers the eye rays
    std::string choice;                          // what decided, for RenderStats::eyeRaysChoice
};

// The eye-ray path for a render of `scene` with `encoding`. A scene with patches takes the kernel
// whatever was asked (the raster pass has no patch hulls; a notice goes to `err` when the raster
// pass was asked for). Auto takes the kernel for polar16
// directions (the raster pass traces exact ones) and on a software OpenGL renderer (slower
// there), the raster pass on a hardware one or when a raster option asks for it. Depth-buffer
// warnings and the notice of a missing OpenGL context go to `err`; throws GlError when the raster
// pass is asked for and no context can be made. `beforeOpenGl` runs before the OpenGL context
// is made, and only then: OpenGL drivers built on LLVM (llvmpipe, radeonsi) start the same libLLVM
// as PoCL, and LLVM's start (its global target registry and options) is not thread-safe, so a
// caller starting an OpenCL device on another thread waits for it there.
EyeRays ChooseEyeRays(const EyeRayRequest& request, render::RayEncoding encoding,
                      const scene::Scene& scene, std::ostream& err,
                      const std::function<void()>& beforeOpenGl);

}  // namespace rayclass::raster
