#include "render_args.h"

#include <cstdio>
#include <sstream>
#include <utility>

#include "image_choices.h"
#include "rayclass/classify/params.h"
#include "rayclass/cli/option_table.h"
#include "rayclass/core/error.h"
#include "rayclass/scene/patch.h"

namespace rayclass::cli {

namespace {

constexpr render::Named<bool Aovs::*> kAovNames[] = {
    {"depth", &Aovs::depth}, {"id", &Aovs::id}, {"normal", &Aovs::normal}};

constexpr render::Named<image::PngCompression> kPngCompressions[] = {
    {"fast", image::PngCompression::kFast},
    {"small", image::PngCompression::kSmall},
    {"none", image::PngCompression::kNone}};
constexpr render::Named<int> kDepthBits[] = {{"16", 16}, {"24", 24}, {"32", 32}};

constexpr const char* kUsageHead = R"(usage: rayclass render SCENE -o OUT.{exr,png} [options]

SCENE is a JSON scene file or a bare OBJ mesh (framed by a default camera and lit from it).

options:
)";

constexpr const char* kUsageTail = R"(
Kernel binaries are cached in $RAYCLASS_CACHE_DIR (else $XDG_CACHE_HOME/rayclass, else
~/.cache/rayclass); RAYCLASS_CACHE_DIR=off builds them from source every time.
)";

void ParseAovs(const std::string& list, Aovs& aovs) {
    std::stringstream names(list);
    std::string name;
    while (std::getline(names, name, ',')) {
        const auto layer = render::FindChoice(kAovNames, name);
        if (!layer) throw UsageError("unknown AOV '" + name + "' (use depth, id, normal)");
        aovs.*(*layer) = true;
    }
}

// `apply` for an option that only the raster pass reads: the first one given is remembered.
template <typename Apply>
auto RasterOnly(RenderArgs& r, Apply apply) {
    return [&r, apply](const std::string& option, const std::string& value) {
        if (r.eyeRays.rasterOption.empty()) r.eyeRays.rasterOption = option;
        apply(option, value);
    };
}

std::vector<Option> OutputOptions(RenderArgs& r) {
    return {
        {{"-o", "--output"},
         "FILE",
         "output image; .exr (float RGB + AOV layers) or .png (8-bit sRGB)",
         Text(r.output)},
        {{"--width"}, "W", "", Number(r.width, 1u, 16384u)},
        {{"--height"},
         "H",
         "override the scene camera's resolution (1..16384)",
         Number(r.height, 1u, 16384u)},
        {{"--aov"},
         "LIST",
         "extra EXR layers of the first hit: any of depth,id,normal",
         [&r](const std::string&, const std::string& v) { ParseAovs(v, r.aovs); }},
        {{"--max-depth"},
         "N",
         "deepest secondary ray (eye rays are depth 0; default 6)",
         Number(r.options.maxDepth, 0u, 64u)},
        {{"--min-weight"},
         "W",
         "secondary rays weaker than W are not spawned (default 0.001)",
         Number(r.options.minWeight, 0.0f, 1.0f)},
        {{"--device"},
         "D",
         "OpenCL device: auto (first GPU, else CPU), gpu, cpu or an index\n"
         "from 'rayclass devices' (default auto)",
         Text(r.device)},
    };
}

// "X0,Y0,X1,Y1": pixel bounds, end exclusive, of a non-empty rectangle.
image::PixelRect ParseCrop(const std::string& option, const std::string& value) {
    std::vector<std::string> parts(1);
    for (char c : value) {
        if (c == ',') {
            parts.emplace_back();
        } else {
            parts.back() += c;
        }
    }
    if (parts.size() != 4) {
        throw UsageError(option + " expects X0,Y0,X1,Y1 (pixel bounds, end exclusive), not '" +
                         value + "'");
    }
    uint32_t v[4];
    for (int k = 0; k < 4; ++k) {
        v[k] = ParseNumber<uint32_t>(option, parts[k], 0u, 16384u, "pixel bounds X0,Y0,X1,Y1");
    }
    const image::PixelRect crop{v[0], v[1], v[2], v[3]};
    if (crop.Empty()) {
        throw UsageError(option + " " + value + " is empty (X1 must exceed X0 and Y1 Y0)");
    }
    return crop;
}

// "I/N": tile I (from 0) of N.
std::array<uint32_t, 2> ParseTile(const std::string& option, const std::string& value) {
    const auto slash = value.find('/');
    if (slash == std::string::npos) {
        throw UsageError(option + " expects I/N (tile I of N, from 0), not '" + value + "'");
    }
    const uint32_t count =
        ParseNumber<uint32_t>(option, value.substr(slash + 1), 1u, 65536u, "a tile count N");
    const uint32_t index =
        ParseNumber<uint32_t>(option, value.substr(0, slash), 0u, count - 1, "a tile index I");
    return {index, count};
}

// "A:B": frames A to B, both included.
std::array<uint32_t, 2> ParseFrames(const std::string& option, const std::string& value) {
    const auto colon = value.find(':');
    if (colon == std::string::npos) {
        throw UsageError(option + " expects A:B (frames A to B, both included), not '" + value +
                         "'");
    }
    const uint32_t first =
        ParseNumber<uint32_t>(option, value.substr(0, colon), 0u, 999999u, "a first frame A");
    const uint32_t last =
        ParseNumber<uint32_t>(option, value.substr(colon + 1), first, 999999u, "a last frame B");
    return {first, last};
}

std::vector<Option> PartOptions(RenderArgs& r) {
    return {
        {{"--crop"},
         "X0,Y0,X1,Y1",
         "render only these pixels (end exclusive), each as the whole render\n"
         "has it; an EXR keeps them in its data window inside the full image",
         [&r](const std::string& o, const std::string& v) { r.crop = ParseCrop(o, v); }},
        {{"--tile"},
         "I/N",
         "render tile I (0..N-1) of N compact tiles, as --crop would; 'rayclass\n"
         "merge' puts the tiles together",
         [&r](const std::string& o, const std::string& v) { r.tile = ParseTile(o, v); }},
        {{"--frame"},
         "K",
         "",
         [&r](const std::string& o, const std::string& v) {
             const uint32_t k = ParseNumber<uint32_t>(o, v, 0u, 999999u, "a frame");
             r.frames = std::array<uint32_t, 2>{k, k};
         }},
        {{"--frames"},
         "A:B",
         "frame K, or frames A to B, of the scene camera's path, each to\n"
         "OUT_####.exr (its --stats to FILE_####.json)",
         [&r](const std::string& o, const std::string& v) { r.frames = ParseFrames(o, v); }},
    };
}

std::vector<Option> QueryOptions(RenderArgs& r) {
    return {
        {{"--accel"},
         "A",
         "ray query: auto (default: per generation, the classification\n"
         "until a sample shows the BVH cheaper), classify (5D ray\n"
         "classification), bvh (binned-SAH BVH, same kernels' routines),\n"
         "brute, kdtree (SAH kd-tree), grid (uniform grid, 3D-DDA) or\n"
         "cones (hierarchical ray engine: rays in cones, primitives culled\n"
         "per cone)",
         Choice(r.options.accel, render::kAccels)},
        {{"--kernel"},
         "K",
         "classified query kernels: auto (default), vertex, fragment, scalar",
         Choice(r.options.kernel, render::kKernelStyles)},
        {{"--classify"},
         "NAME=VALUE",
         "a cost-function setting of the classification (repeatable): min-rays,\n"
         "min-candidates, light-min-candidates (min-candidates of the light\n"
         "cells' shadow rays), splits-per-list, split (midpoint|median),\n"
         "min-origin-fraction, min-dir-fraction, dir-weight, threads\n"
         "(classification threads, 0 = one per core), task-rays, plan-rays,\n"
         "light-cells (auto|off|N: shadow rays sorted by direction cells),\n"
         "vertex-gather (--kernel auto's price of a vertex-style block)",
         [&r](const std::string& o, const std::string& v) {
             const auto [name, value] = NameValue(o, v);
             r.options.classifyParams.push_back(classify::ParseParam(name, value));
         }},
        {{"--ray-encoding"},
         "E",
         "ray directions as float (default) or polar16: packed 16-bit polar\n"
         "angles, the thesis's compact form (costs accuracy, see README)",
         Choice(r.options.rayEncoding, render::kRayEncodings)},
        {{"--triangle-test"},
         "T",
         "moller (default) or watertight (Woop et al. 2013; brute, scalar and\n"
         "--reference paths: classified queries then run the scalar kernels)",
         Choice(r.options.triangleTest, render::kTriangleTests)},
        {{"--reference"},
         "",
         "render with the double-precision host reference renderer",
         Flag(r.reference)},
        {{"--patch-boxes"},
         "N",
         "boxes per Bezier or NURBS patch, the least flat halved first\n"
         "(default: halved by the scene's patch_flatness)",
         Number(r.patchBoxes, 1u, scene::kMaxPatchBoxes)},
    };
}

std::vector<Option> FileOptions(RenderArgs& r) {
    return {
        {{"--stats"}, "FILE.json", "write ray counts and timings as JSON", Text(r.statsFile)},
        {{"--exposure"},
         "E",
         "PNG only: scale by 2^E before tone mapping (default 0)",
         Number(r.exposure, -64.0f, 64.0f)},
        {{"--exr-compression"},
         "C",
         "zip (default), piz or none: lossless; float radiance compresses\n"
         "poorly, and ZIP can take longer than a short render (see README)",
         Choice(r.exrCompression, kExrCompressions)},
        {{"--png-compression"},
         "C",
         "fast (default: run-length deflate, 6x quicker to write), small\n"
         "(libpng's defaults, files about a fifth smaller) or none",
         Choice(r.pngCompression, kPngCompressions)},
        {{"--batch-rays"},
         "N",
         "rays per kernel launch (default 262144)",
         Number(r.options.batchRays, 64u, 1u << 24)},
        {{"--cl-options"},
         "STRING",
         "extra OpenCL build options (e.g. -cl-fast-relaxed-math)",
         Text(r.options.buildOptions)},
    };
}

std::vector<Option> EyeRayOptions(RenderArgs& r) {
    raster::RasterOptions& pass = r.eyeRays.raster;
    return {
        {{"--eye-rays"},
         "P",
         "first hits of the eye rays: raster (OpenGL hull projection, headless\n"
         "EGL), kernel (the OpenCL ray query) or auto (default): raster on a\n"
         "hardware OpenGL renderer or when a raster option is given, kernel on\n"
         "a software one (llvmpipe: slower there) or without OpenGL (a notice)",
         [&r](const std::string&, const std::string& v) {
             const auto path = render::FindChoice(raster::kEyeRayPaths, v);
             if (!path) {
                 throw UsageError("--eye-rays expects auto, raster or kernel, not '" + v + "'");
             }
             r.eyeRays.path = *path;
         }},
        {{"--hull"},
         "H",
         "raster hulls of spheres and quadrics: sphere, box, billboard or auto\n"
         "(spheres by sphere, quadrics by box; default auto)",
         RasterOnly(r, [&pass](const std::string&,
                               const std::string& v) { pass.hull = raster::ParseHull(v); })},
        {{"--depth-bits"},
         "B",
         "raster depth buffer: 32 (float, default), 24 or 16 (fixed point)",
         RasterOnly(r, Choice(pass.depthBits, kDepthBits))},
        {{"--depth-scale"},
         "S",
         "raster depth per world unit, in [1e-30, 1e+30], or auto (default: the\n"
         "largest power of two keeping the scene's distances below 1, which\n"
         "float depth compares exactly); settings that can lose hits or swap\n"
         "the ids of close surfaces get a warning",
         RasterOnly(r,
                    [&pass](const std::string& o, const std::string& v) {
                        pass.depthScale =
                            v == "auto" ? 0.0 : ParseNumber<double>(o, v, 1e-30, 1e30);
                    })},
        {{"-q", "--quiet"}, "", "no progress line", Flag(r.options.progress, false)},
    };
}

// Every option, in the order --help lists them, applied to `r`.
OptionTable RenderOptionTable(RenderArgs& r) {
    std::vector<Option> options;
    for (auto part : {OutputOptions, PartOptions, QueryOptions, FileOptions, EyeRayOptions}) {
        for (Option& option : part(r)) options.push_back(std::move(option));
    }
    return OptionTable(std::move(options), " (see 'rayclass render --help')");
}

std::string Extension(const std::string& path) {
    const auto dot = path.find_last_of('.');
    const auto slash = path.find_last_of('/');
    if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
    std::string ext = path.substr(dot);
    for (auto& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

// The checks that concern the output files: its format and the options it takes.
void ValidateOutputs(const RenderArgs& r) {
    if (r.scene.empty()) throw UsageError("no scene given (see 'rayclass render --help')");
    if (r.output.empty()) throw UsageError("no output given: -o OUT.exr or -o OUT.png");
    const std::string ext = Extension(r.output);
    if (ext != ".exr" && ext != ".png") {
        throw UsageError(r.output + ": unsupported output format '" + ext + "' (use .exr or .png)");
    }
    if (r.aovs.Any() && ext != ".exr") throw UsageError("--aov needs an .exr output");
    if (r.exrCompression && ext != ".exr") {
        throw UsageError("--exr-compression needs an .exr output");
    }
    if (r.pngCompression && ext != ".png") {
        throw UsageError("--png-compression needs a .png output");
    }
}

// The checks of options that ask for what the chosen path does not run: silently ignoring them
// would pass off one kind of image as another.
void ValidatePaths(const RenderArgs& r) {
    const raster::EyeRayRequest& eye = r.eyeRays;
    const bool kernelEyeRays = eye.path == raster::EyeRayPath::kKernel;
    if (!eye.rasterOption.empty() && (r.reference || kernelEyeRays)) {
        throw UsageError(eye.rasterOption + " sets up the raster eye-ray pass, which " +
                         (r.reference ? "--reference" : "--eye-rays kernel") + " does not run");
    }
    // The raster pass finds the hits of exact eye directions: under polar16 they would not be the
    // hits of the rounded rays the kernels shade.
    const bool polar16 = r.options.rayEncoding == render::RayEncoding::kPolar16;
    if (polar16 && !r.reference && eye.RasterAsked()) {
        throw UsageError("--ray-encoding polar16 needs kernel eye rays: the raster pass (" +
                         (eye.path == raster::EyeRayPath::kRaster ? std::string("--eye-rays raster")
                                                                  : eye.rasterOption) +
                         ") traces exact eye directions");
    }
    // The reference traces exact directions in double.
    if (polar16 && r.reference) {
        throw UsageError(
            "--ray-encoding polar16 rounds the kernels' ray directions, which "
            "--reference does not run");
    }
}

void Validate(const RenderArgs& r) {
    ValidateOutputs(r);
    ValidatePaths(r);
    if (r.crop && r.tile) throw UsageError("--crop and --tile both choose the pixels: give one");
    if (!r.statsFile.empty() && Extension(r.statsFile) != ".json") {
        throw UsageError("--stats expects a .json file, not '" + r.statsFile + "'");
    }
    const render::KernelStyle kernel = r.options.kernel;
    if (r.options.triangleTest == render::TriangleTest::kWatertight &&
        (kernel == render::KernelStyle::kVertex || kernel == render::KernelStyle::kFragment)) {
        throw UsageError("--triangle-test watertight needs --kernel scalar or auto (the " +
                         std::string(render::NameOf(render::kKernelStyles, kernel)) +
                         " kernels test triangles with Moeller-Trumbore)");
    }
}

}  // namespace

std::string FrameFile(const std::string& path, uint32_t frame) {
    const std::string ext = Extension(path);
    char number[16];
    std::snprintf(number, sizeof number, "_%04u", frame);
    return path.substr(0, path.size() - ext.size()) + number + ext;
}

RenderArgs ParseRenderArgs(const std::vector<std::string>& args) {
    RenderArgs r;
    RenderOptionTable(r).Parse(args, [&r](const std::string& a) {
        if (!r.scene.empty()) {
            throw UsageError("unexpected argument '" + a + "' (one scene per render)");
        }
        r.scene = a;
    });
    Validate(r);
    r.options.aovs = r.aovs.Any();
    return r;
}

std::string RenderUsage() {
    RenderArgs unused;
    return kUsageHead + RenderOptionTable(unused).Help(24) + kUsageTail;
}

}  // namespace rayclass::cli
