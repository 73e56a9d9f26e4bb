// `rayclass render`'s command line: every option parsed once into typed values, by the table
// that also prints --help, and checked against the others before anything is loaded.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "rayclass/image/image.h"
#include "rayclass/image/tiles.h"
#include "rayclass/raster/eye_rays.h"
#include "rayclass/render/options.h"

namespace rayclass::cli {

// The first-hit layers an EXR output keeps.
struct Aovs {
    bool depth = false, id = false, normal = false;
    bool Any() const { return depth || id || normal; }
};

struct RenderArgs {
    std::string scene, output, statsFile;
    uint32_t width = 0, height = 0;  // 0: the scene camera's
    Aovs aovs;
    bool reference = false;
    float exposure = 0.0f;
    std::optional<image::ExrCompression> exrCompression;  // none: the writer's default
    std::optional<image::PngCompression> pngCompression;  // none: the writer's default
    // The OpenCL device, as clrt::Context reads it where the context is made: a bad one is
    // reported after the scene, which loads meanwhile.
    std::string device = "auto";
    raster::EyeRayRequest eyeRays;
    render::RenderOptions options;
    // The part of the image to render: --crop's pixels or --tile's index and count (the window
    // goes into options once the image size is known).
    std::optional<image::PixelRect> crop;
    std::optional<std::array<uint32_t, 2>> tile;
    // --frame K or --frames A:B: the first and last frame (inclusive) of the scene's camera path,
    // each written to OUT_####.ext (and its stats to FILE_####.json).
    std::optional<std::array<uint32_t, 2>> frames;
};

// `path` with "_" and the frame number (4 digits at least) before its extension.
std::string FrameFile(const std::string& path, uint32_t frame);

// `args` (after "render") parsed and checked; throws UsageError naming the first problem.
RenderArgs ParseRenderArgs(const std::vector<std::string>& args);

// The text of `rayclass render --help`.
std::string RenderUsage();

}  // namespace rayclass::cli
