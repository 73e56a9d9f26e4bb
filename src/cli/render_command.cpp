#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <future>
#include <memory>
#include <optional>
#include <ostream>
#include <string>

#include "rayclass/cli/cli.h"
#include "rayclass/clrt/context.h"
#include "rayclass/core/error.h"
#include "rayclass/image/image.h"
#include "rayclass/raster/eye_rays.h"
#include "rayclass/render/cl_renderer.h"
#include "rayclass/render/reference.h"
#include "rayclass/scene/loader.h"
#include "rayclass/scene/patch.h"
#include "render_args.h"
#include "render_hash.h"

namespace rayclass::cli {

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
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

// The OpenCL device and the frames' program, started on a worker thread when the command starts:
// PoCL's start and its load of the program then overlap the scene load and the choice of eye
// rays, the load of the program also the render's set-up that needs only the device, and every
// frame of --frames shares the one program.
class DeviceStart {
  public:
    explicit DeviceStart(const RenderArgs& r)
        : context_(contextSet_.get_future()),
          program_(std::async(std::launch::async, &DeviceStart::Start, this, r.device, r.options)) {
    }
    DeviceStart(const DeviceStart&) = delete;
    DeviceStart& operator=(const DeviceStart&) = delete;
    ~DeviceStart() { abandoned_ = true; }  // then program_ waits for the worker

    // Wait for the device the first time; rethrow its error.
    clrt::Context& Context() { return *context_.get(); }
    // Wait for the program the first time; rethrow the device's error, and the program build's.
    const render::FrameProgram& Program() {
        if (!built_) built_ = program_.get();
        return *built_;
    }

  private:
    // On the worker: the device, then its program, unless the command failed meanwhile (a bad
    // scene) and need not wait for a build from source.
    render::FrameProgram Start(const std::string& spec, const render::RenderOptions& options) {
        try {
            ctx_ = std::make_unique<clrt::Context>(spec);
        } catch (...) {
            contextSet_.set_exception(std::current_exception());
            throw;
        }
        contextSet_.set_value(ctx_.get());
        if (abandoned_) return {};
        return render::BuildFrameProgram(*ctx_, options);
    }

    std::atomic<bool> abandoned_{false};
    std::unique_ptr<clrt::Context> ctx_;  // set by the worker before contextSet_
    std::promise<clrt::Context*> contextSet_;
    std::shared_future<clrt::Context*> context_;
    std::optional<render::FrameProgram> built_;
    std::future<render::FrameProgram> program_;  // last: destroyed (awaited) first
};

// The render on the started device, its eye rays' first hits from the path that
// raster::ChooseEyeRays picks while the device may still be starting: an OpenGL context waits
// for the device, whose start and the driver's may share one libLLVM.
image::Image RenderOnDevice(const RenderArgs& r, const scene::Scene& scene,
                            const render::RenderOptions& options, DeviceStart& device,
                            render::RenderStats& stats, std::ostream& err) {
    raster::EyeRays eyeRays;
    try {
        eyeRays = raster::ChooseEyeRays(r.eyeRays, options.rayEncoding, scene, err,
                                        [&device] { device.Context(); });
    } catch (...) {
        device.Context();  // a bad device is reported first, as when it was awaited first
        throw;
    }
    stats.eyeRaysChoice = eyeRays.choice;
    render::ClRenderer renderer(device.Context(), scene, options, eyeRays.hits.get());
    renderer.AwaitProgram([&device] { return device.Program(); });
    return renderer.Render(stats);
}

// The pixels to render: --crop's, --tile's, or all of them.
std::optional<image::PixelRect> WindowOf(const RenderArgs& r, const scene::Camera& camera) {
    if (r.tile) return image::TileRect((*r.tile)[0], (*r.tile)[1], camera.width, camera.height);
    return r.crop;
}

// Drops the first-hit layers that were not asked for.
void KeepAovs(const Aovs& aovs, image::Image& img) {
    if (!aovs.depth) img.depth.clear();
    if (!aovs.id) img.id.clear();
    if (!aovs.normal) img.normal.clear();
}

image::WriteOptions WriteOptionsOf(const RenderArgs& r) {
    image::WriteOptions options;
    options.exposure = r.exposure;
    if (r.exrCompression) options.exrCompression = *r.exrCompression;
    if (r.pngCompression) options.pngCompression = *r.pngCompression;
    return options;
}

// One image of the scene as it stands: rendered, written to `output` and its stats to
// `statsPath` (none when empty; the temporary is made before the render, see PendingTextFile).
// `t0` is when this image's work began, `loadSeconds` what loading the scene took of it.
void RenderImage(const RenderArgs& r, const scene::Scene& scene, DeviceStart* device,
                 const std::string& output, const std::string& statsPath, render::RenderPart part,
                 Clock::time_point t0, double loadSeconds, std::ostream& err) {
    std::optional<PendingTextFile> statsFile;
    if (!statsPath.empty()) statsFile.emplace(statsPath);
    render::RenderOptions options = r.options;
    options.window = WindowOf(r, scene.camera);
    options.newtonStats = statsFile.has_value();
    render::RenderStats stats;
    stats.part = part;
    if (r.tile) stats.part.tile = r.tile;
    if (options.window) {
        const image::PixelRect& w = *options.window;
        stats.part.crop = {w.x0, w.y0, w.x1, w.y1};
    }
    image::Image img = r.reference ? render::RenderReference(scene, options, stats)
                                   : RenderOnDevice(r, scene, options, *device, stats, err);
    KeepAovs(r.aovs, img);
    img.sceneHash = RenderHash(scene, options, r.reference);

    // The total stops before the image is written: the stats are on disk first (see Write).
    stats.timeS["scene_load"] = loadSeconds;
    stats.timeS["total"] = SecondsSince(t0);
    if (statsFile) statsFile->Write(stats.ToJson().dump(2) + "\n");
    image::WriteImage(img, output, WriteOptionsOf(r));
    if (statsFile) statsFile->Commit();
    if (r.options.progress) {
        err << "rayclass: " << output << " (" << img.width << "x" << img.height << ", "
            << stats.RaysTotal() << " rays, " << stats.timeS["total"] << " s)\n";
    }
}

// --frame / --frames: each frame's camera from the path, checked before any is rendered.
std::vector<scene::Camera> FrameCameras(const RenderArgs& r, const scene::Scene& scene) {
    if (scene.cameraPath.Empty()) {
        throw Error(r.scene + ": --frame and --frames need a camera 'path' in the scene");
    }
    std::vector<scene::Camera> cameras;
    for (uint32_t k = (*r.frames)[0]; k <= (*r.frames)[1]; ++k) {
        cameras.push_back(scene.cameraPath.At(scene.camera, k));
    }
    return cameras;
}

}  // namespace

int RenderCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
    for (const auto& a : args) {
        if (a == "--help" || a == "-h") {
            out << RenderUsage();
            return 0;
        }
    }
    const auto t0 = Clock::now();
    const RenderArgs r = ParseRenderArgs(args);
    // A stats path that cannot be written fails before the scene loads.
    if (!r.statsFile.empty() && !r.frames) PendingTextFile check(r.statsFile);

    // The OpenCL platform starts (a visible part of a one-frame render with PoCL) while the
    // scene loads on one core. Errors keep their order: a bad scene is reported before a bad
    // device.
    std::optional<DeviceStart> device;
    if (!r.reference) device.emplace(r);
    scene::Scene scene = scene::LoadScene(r.scene);
    if (r.patchBoxes) scene::SplitPatches(scene, {scene.patchFlatness, r.patchBoxes});
    if (r.width) scene.camera.width = r.width;
    if (r.height) scene.camera.height = r.height;
    const double loadSeconds = SecondsSince(t0);
    const std::vector<scene::Camera> cameras =
        r.frames ? FrameCameras(r, scene) : std::vector<scene::Camera>{};
    DeviceStart* started = device ? &*device : nullptr;
    if (!r.frames) {
        RenderImage(r, scene, started, r.output, r.statsFile, {}, t0, loadSeconds, err);
        return 0;
    }
    for (size_t i = 0; i < cameras.size(); ++i) {
        const auto tFrame = i == 0 ? t0 : Clock::now();
        const uint32_t k = (*r.frames)[0] + uint32_t(i);
        scene.camera = cameras[i];
        render::RenderPart part;
        part.frame = k;
        part.frameTime = scene.cameraPath.TimeOf(k);
        RenderImage(r, scene, started, FrameFile(r.output, k),
                    r.statsFile.empty() ? "" : FrameFile(r.statsFile, k), part, tFrame,
                    i == 0 ? loadSeconds : 0.0, err);
    }
    return 0;
}

}  // namespace rayclass::cli
