#include <unistd.h>

#include <charconv>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <future>
#include <initializer_list>
#include <memory>
#include <optional>
#include <ostream>
#include <set>
#include <sstream>
#include <string>
#include <string_view>

#include "rayclass/classify/params.h"
#include "rayclass/cli/cli.h"
#include "rayclass/clrt/context.h"
#include "rayclass/core/error.h"
#include "rayclass/image/image.h"
#include "rayclass/raster/raster_pass.h"
#include "rayclass/render/cl_renderer.h"
#include "rayclass/render/classified_query.h"
#include "rayclass/render/reference.h"
#include "rayclass/scene/loader.h"

namespace rayclass::cli {

namespace {

constexpr const char* kRenderUsage = R"(usage: rayclass render SCENE -o OUT.{exr,png} [options]

SCENE is a JSON scene file or a bare OBJ mesh (framed by a default camera and lit from it).

options:
  -o, --output FILE       output image; .exr (float RGB + AOV layers) or .png (8-bit sRGB)
  --width W, --height H   override the scene camera's resolution (1..16384)
  --aov LIST              extra EXR layers of the first hit: any of depth,id,normal
  --max-depth N           deepest secondary ray (eye rays are depth 0; default 6)
  --min-weight W          secondary rays weaker than W are not spawned (default 0.001)
  --device D              OpenCL device: auto (first GPU, else CPU), gpu, cpu or an index
                          from 'rayclass devices' (default auto)
  --accel A               ray query: classify (5D ray classification, default), bvh
                          (binned-SAH BVH, same kernels' routines), auto (per generation,
                          the classification until a sample shows the BVH cheaper) or brute
  --kernel K              classified query kernels: auto (default), vertex, fragment, scalar
  --classify NAME=VALUE   a cost-function setting of the classification (repeatable): min-rays,
                          min-candidates, splits-per-list, split (midpoint|median),
                          min-origin-fraction, min-dir-fraction, dir-weight, threads
                          (classification threads, 0 = one per core), task-rays, plan-rays,
                          light-cells (auto|off|N: shadow rays sorted by direction cells),
                          vertex-gather (--kernel auto's price of a vertex-style block)
  --ray-encoding E        ray directions as float (default) or polar16: packed 16-bit polar
                          angles, the thesis's compact form (costs accuracy, see README)
  --triangle-test T       moller (default) or watertight (Woop et al. 2013; brute, scalar and
                          --reference paths: classified queries then run the scalar kernels)
  --reference             render with the double-precision host reference renderer
  --stats FILE.json       write ray counts and timings as JSON
  --exposure E            PNG only: scale by 2^E before tone mapping (default 0)
  --exr-compression C     zip (default), piz or none: lossless; float radiance compresses
                          poorly, and ZIP can take longer than a short render (see README)
  --png-compression C     fast (default: run-length deflate, 6x quicker to write), small
                          (libpng's defaults, files about a fifth smaller) or none
  --batch-rays N          rays per kernel launch (default 1048576)
  --cl-options STRING     extra OpenCL build options (e.g. -cl-fast-relaxed-math)
  --eye-rays P            first hits of the eye rays: raster (OpenGL hull projection, headless
                          EGL), kernel (the OpenCL ray query) or auto (default): raster on a
                          hardware OpenGL renderer or when a raster option is given, kernel on
                          a software one (llvmpipe: slower there) or without OpenGL (a notice)
  --hull H                raster hulls of spheres and quadrics: sphere, box, billboard or auto
                          (spheres by sphere, quadrics by box; default auto)
  --depth-bits B          raster depth buffer: 32 (float, default), 24 or 16 (fixed point)
  --depth-scale S         raster depth per world unit, in [1e-30, 1e+30], or auto (default: the
                          largest power of two keeping the scene's distances below 1, which
                          float depth compares exactly); settings that can lose hits or swap
                          the ids of close surfaces get a warning
  -q, --quiet             no progress line

Kernel binaries are cached in $RAYCLASS_CACHE_DIR (else $XDG_CACHE_HOME/rayclass, else
~/.cache/rayclass); RAYCLASS_CACHE_DIR=off builds them from source every time.
)";

struct RenderArgs {
    std::string scene;
    std::string output;
    uint32_t width = 0, height = 0;
    std::set<std::string> aovs;
    bool reference = false;
    std::string statsFile;
    float exposure = 0.0f;
    std::string exrCompression;  // empty: the writer's default (zip)
    std::string pngCompression;  // empty: the writer's default (fast)
    std::string eyeRays = "auto";  // auto, raster or kernel (see --help)
    int depthBits = 32;
    double depthScale = 0;  // 0: automatic
    std::string rasterOption;  // the first option given that only the raster pass reads
    render::RenderOptions options;
};

template <typename T>
T ParseNumber(const std::string& option, const std::string& text, T lo, T hi) {
    T value{};
    const char* end = text.data() + text.size();
    auto [ptr, ec] = std::from_chars(text.data(), end, value);
    if (ec != std::errc() || ptr != end || !(value >= lo && value <= hi)) {
        std::ostringstream msg;
        msg << option << " expects a number in [" << lo << ", " << hi << "], not '" << text << "'";
        throw UsageError(msg.str());
    }
    return value;
}

// `value` when it is one of `names`, else a UsageError "OPTION must be a, b or c, not 'value'".
const std::string& OneOf(const std::string& option, const std::string& value,
                         std::initializer_list<std::string_view> names) {
    std::string list;
    size_t k = 0;
    for (const std::string_view name : names) {
        if (value == name) return value;
        if (k++ > 0) list += k == names.size() ? " or " : ", ";
        list += name;
    }
    throw UsageError(option + " must be " + list + ", not '" + value + "'");
}

std::string Extension(const std::string& path) {
    const auto dot = path.find_last_of('.');
    const auto slash = path.find_last_of('/');
    if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
    std::string ext = path.substr(dot);
    for (auto& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
    return ext;
}

RenderArgs ParseRenderArgs(const std::vector<std::string>& args) {
    RenderArgs r;
    for (size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        auto value = [&]() -> const std::string& {
            if (i + 1 >= args.size()) throw UsageError(a + " needs a value");
            return args[++i];
        };
        if (a == "-o" || a == "--output") {
            r.output = value();
        } else if (a == "--width") {
            r.width = ParseNumber<uint32_t>(a, value(), 1, 16384);
        } else if (a == "--height") {
            r.height = ParseNumber<uint32_t>(a, value(), 1, 16384);
        } else if (a == "--aov") {
            std::stringstream list(value());
            std::string name;
            while (std::getline(list, name, ',')) {
                if (name != "depth" && name != "id" && name != "normal") {
                    throw UsageError("unknown AOV '" + name + "' (use depth, id, normal)");
                }
                r.aovs.insert(name);
            }
        } else if (a == "--max-depth") {
            r.options.maxDepth = ParseNumber<uint32_t>(a, value(), 0, 64);
        } else if (a == "--min-weight") {
            r.options.minWeight = ParseNumber<float>(a, value(), 0.0f, 1.0f);
        } else if (a == "--device") {
            r.options.device = value();
        } else if (a == "--accel") {
            r.options.accel = OneOf(a, value(), {"classify", "bvh", "auto", "brute"});
        } else if (a == "--classify") {
            const std::string& setting = value();
            const auto eq = setting.find('=');
            if (eq == std::string::npos) {
                throw UsageError("--classify expects NAME=VALUE, not '" + setting + "'");
            }
            classify::Params probe;
            classify::SetParam(probe, setting.substr(0, eq), setting.substr(eq + 1));
            r.options.classifyParams.emplace_back(setting.substr(0, eq), setting.substr(eq + 1));
        } else if (a == "--kernel") {
            r.options.kernel = value();
            render::ParseKernelStyle(r.options.kernel);
        } else if (a == "--ray-encoding") {
            r.options.rayEncoding = OneOf(a, value(), {"float", "polar16"});
        } else if (a == "--triangle-test") {
            r.options.triangleTest = OneOf(a, value(), {"moller", "watertight"});
        } else if (a == "--reference") {
            r.reference = true;
        } else if (a == "--stats") {
            r.statsFile = value();
        } else if (a == "--exposure") {
            r.exposure = ParseNumber<float>(a, value(), -64.0f, 64.0f);
        } else if (a == "--exr-compression") {
            r.exrCompression = OneOf(a, value(), {"zip", "piz", "none"});
        } else if (a == "--png-compression") {
            r.pngCompression = OneOf(a, value(), {"fast", "small", "none"});
        } else if (a == "--batch-rays") {
            r.options.batchRays = ParseNumber<uint32_t>(a, value(), 64, 1u << 24);
        } else if (a == "--cl-options") {
            r.options.buildOptions = value();
        } else if (a == "--eye-rays") {
            r.eyeRays = value();
            if (r.eyeRays != "auto" && r.eyeRays != "raster" && r.eyeRays != "kernel") {
                throw UsageError("--eye-rays expects auto, raster or kernel, not '" + r.eyeRays +
                                 "'");
            }
        } else if (a == "--hull") {
            if (r.rasterOption.empty()) r.rasterOption = a;
            r.options.hull = value();
            raster::ParseHull(r.options.hull);  // throws UsageError on an unknown name
        } else if (a == "--depth-bits") {
            if (r.rasterOption.empty()) r.rasterOption = a;
            r.depthBits = std::stoi(OneOf(a, value(), {"16", "24", "32"}));
        } else if (a == "--depth-scale") {
            if (r.rasterOption.empty()) r.rasterOption = a;
            const std::string& scale = value();
            r.depthScale = scale == "auto" ? 0.0 : ParseNumber<double>(a, scale, 1e-30, 1e30);
        } else if (a == "-q" || a == "--quiet") {
            r.options.progress = false;
        } else if (!a.empty() && a[0] == '-') {
            throw UsageError("unknown option '" + a + "' (see 'rayclass render --help')");
        } else if (r.scene.empty()) {
            r.scene = a;
        } else {
            throw UsageError("unexpected argument '" + a + "' (one scene per render)");
        }
    }
    if (r.scene.empty()) throw UsageError("no scene given (see 'rayclass render --help')");
    if (r.output.empty()) throw UsageError("no output given: -o OUT.exr or -o OUT.png");
    const std::string ext = Extension(r.output);
    if (ext != ".exr" && ext != ".png") {
        throw UsageError(r.output + ": unsupported output format '" + ext + "' (use .exr or .png)");
    }
    if (!r.aovs.empty() && ext != ".exr") throw UsageError("--aov needs an .exr output");
    if (!r.exrCompression.empty() && ext != ".exr") {
        throw UsageError("--exr-compression needs an .exr output");
    }
    if (!r.pngCompression.empty() && ext != ".png") {
        throw UsageError("--png-compression needs a .png output");
    }
    // Silently ignoring them would pass off a kernel or reference image as a raster experiment.
    if (!r.rasterOption.empty() && (r.reference || r.eyeRays == "kernel")) {
        throw UsageError(r.rasterOption + " sets up the raster eye-ray pass, which " +
                         (r.reference ? "--reference" : "--eye-rays kernel") + " does not run");
    }
    // The raster pass finds the hits of exact eye directions: under polar16 they would not be the
    // hits of the rounded rays the kernels shade (71 of the default scene's pixels differ).
    if (r.options.rayEncoding == "polar16" && !r.reference &&
        (r.eyeRays == "raster" || !r.rasterOption.empty())) {
        throw UsageError(
            "--ray-encoding polar16 needs kernel eye rays: the raster pass (" +
            (r.eyeRays == "raster" ? std::string("--eye-rays raster") : r.rasterOption) +
            ") traces exact eye directions");
    }
    // The reference traces exact directions in double: ignoring polar16 would pass off an exact
    // image as a polar16 one.
    if (r.options.rayEncoding == "polar16" && r.reference) {
        throw UsageError(
            "--ray-encoding polar16 rounds the kernels' ray directions, which "
            "--reference does not run");
    }
    if (!r.statsFile.empty() && Extension(r.statsFile) != ".json") {
        throw UsageError("--stats expects a .json file, not '" + r.statsFile + "'");
    }
    if (r.options.triangleTest == "watertight" &&
        (r.options.kernel == "vertex" || r.options.kernel == "fragment")) {
        throw UsageError("--triangle-test watertight needs --kernel scalar or auto (the " +
                         r.options.kernel + " kernels test triangles with Moeller-Trumbore)");
    }
    r.options.aovs = !r.aovs.empty();
    return r;
}

// A text file written through a temporary file and a rename, like the images. The temporary is
// created up front, so that a path that cannot be written fails before anything is rendered and
// no image is left behind by a command that fails; it is removed unless Commit succeeds.
class PendingTextFile {
  public:
    explicit PendingTextFile(std::string path)
        : path_(std::move(path)), tmp_(path_ + ".tmp-" + std::to_string(getpid())) {
        // A directory in the way would only fail the final rename, after the image is written.
        std::error_code ignored;
        if (std::filesystem::is_directory(path_, ignored)) throw Error(path_ + ": cannot write");
        out_.open(tmp_, std::ios::binary);
        if (!out_) throw Error(path_ + ": cannot write");
    }
    PendingTextFile(const PendingTextFile&) = delete;
    PendingTextFile& operator=(const PendingTextFile&) = delete;
    ~PendingTextFile() {
        if (committed_) return;
        out_.close();
        std::remove(tmp_.c_str());
    }

    // Writes `text` to the temporary and closes it. Called before the image is written, so that a
    // full disk fails the command while the previous image is still in place.
    void Write(const std::string& text) {
        out_ << text;
        out_.close();
        if (!out_) throw Error(path_ + ": cannot write");
    }

    // Renames the written temporary over the target.
    void Commit() {
        if (std::rename(tmp_.c_str(), path_.c_str()) != 0) throw Error(path_ + ": cannot write");
        committed_ = true;
    }

  private:
    std::string path_, tmp_;
    std::ofstream out_;
    bool committed_ = false;
};

}  // namespace

int RenderCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
    for (const auto& a : args) {
        if (a == "--help" || a == "-h") {
            out << kRenderUsage;
            return 0;
        }
    }
    using Clock = std::chrono::steady_clock;
    const auto t0 = Clock::now();
    const RenderArgs r = ParseRenderArgs(args);
    std::optional<PendingTextFile> statsFile;
    if (!r.statsFile.empty()) statsFile.emplace(r.statsFile);

    // The OpenCL platform starts (a visible part of a one-frame render with PoCL) while the
    // scene loads on one core. Errors keep their order: a bad scene is reported before a bad
    // device.
    std::future<std::unique_ptr<clrt::Context>> device;
    if (!r.reference) {
        device = std::async(std::launch::async, [spec = r.options.device] {
            return std::make_unique<clrt::Context>(spec);
        });
    }
    scene::Scene scene = scene::LoadScene(r.scene);
    if (r.width) scene.camera.width = r.width;
    if (r.height) scene.camera.height = r.height;
    const double loadSeconds = std::chrono::duration<double>(Clock::now() - t0).count();

    render::RenderStats stats;
    image::Image img;
    if (r.reference) {
        img = render::RenderReference(scene, r.options, stats);
    } else {
        const std::unique_ptr<clrt::Context> context = device.get();
        clrt::Context& ctx = *context;
        render::RenderOptions options = r.options;
        std::unique_ptr<raster::RasterEyeHits> eyeHits;
        // A raster option asks for a raster experiment: auto must not answer it by kernel.
        const bool rasterAsked = r.eyeRays == "raster" || !r.rasterOption.empty();
        if (r.eyeRays == "kernel") {
            stats.eyeRaysChoice = "--eye-rays kernel";
        } else if (options.rayEncoding == "polar16") {
            options.eyeRays = "kernel";
            stats.eyeRaysChoice = "auto: kernel for --ray-encoding polar16";
        } else if (!rasterAsked && raster::OnlySoftwareEglDevices()) {
            options.eyeRays = "kernel";
            stats.eyeRaysChoice = "auto: kernel, software OpenGL only (EGL_MESA_device_software)";
        } else {
            std::string why;
            raster::GlContext* gl = raster::GlContext::Shared(&why);
            if (gl && (rasterAsked || !raster::IsSoftwareRenderer(gl->Renderer()))) {
                raster::RasterOptions rasterOptions;
                rasterOptions.hull = raster::ParseHull(options.hull);
                rasterOptions.depthBits = r.depthBits;
                rasterOptions.depthScale = r.depthScale;
                for (const std::string& warning :
                     raster::DepthWarnings(scene, scene.camera.position, rasterOptions)) {
                    err << "rayclass: warning: " << warning << "\n";
                }
                eyeHits = std::make_unique<raster::RasterEyeHits>(*gl, rasterOptions);
                options.eyeRays = "raster";
                if (r.eyeRays == "raster") {
                    stats.eyeRaysChoice = "--eye-rays raster";
                } else if (rasterAsked) {
                    stats.eyeRaysChoice = "auto: raster for " + r.rasterOption;
                } else {
                    stats.eyeRaysChoice =
                        "auto: raster on hardware OpenGL (" + gl->Renderer() + ")";
                }
            } else if (gl) {
                options.eyeRays = "kernel";
                stats.eyeRaysChoice = "auto: kernel, software OpenGL (" + gl->Renderer() + ")";
            } else if (rasterAsked) {
                throw GlError(why);
            } else {
                err << "rayclass: no OpenGL context, eye rays by kernel (" << why << ")\n";
                options.eyeRays = "kernel";
                stats.eyeRaysChoice = "auto: kernel, no OpenGL context";
            }
        }
        render::ClRenderer renderer(ctx, scene, options, eyeHits.get());
        img = renderer.Render(stats);
    }
    if (!r.aovs.count("depth")) img.depth.clear();
    if (!r.aovs.count("id")) img.id.clear();
    if (!r.aovs.count("normal")) img.normal.clear();

    // The total stops before the image is written: the stats are on disk first (see Write).
    stats.timeS["scene_load"] = loadSeconds;
    stats.timeS["total"] = std::chrono::duration<double>(Clock::now() - t0).count();
    if (statsFile) statsFile->Write(stats.ToJson().dump(2) + "\n");
    image::WriteOptions writeOptions;
    writeOptions.exposure = r.exposure;
    if (r.exrCompression == "piz") writeOptions.exrCompression = image::ExrCompression::kPiz;
    if (r.exrCompression == "none") writeOptions.exrCompression = image::ExrCompression::kNone;
    if (r.pngCompression == "small") writeOptions.pngCompression = image::PngCompression::kSmall;
    if (r.pngCompression == "none") writeOptions.pngCompression = image::PngCompression::kNone;
    image::WriteImage(img, r.output, writeOptions);
    if (statsFile) statsFile->Commit();
    if (r.options.progress) {
        err << "rayclass: " << r.output << " (" << img.width << "x" << img.height << ", "
            << stats.RaysTotal() << " rays, " << stats.timeS["total"] << " s)\n";
    }
    return 0;
}

}  // namespace rayclass::cli
