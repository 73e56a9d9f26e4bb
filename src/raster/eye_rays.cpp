#include "rayclass/raster/eye_rays.h"

#include <ostream>

#include "rayclass/core/error.h"
#include "rayclass/raster/gl.h"

namespace rayclass::raster {

namespace {

// Why the raster pass answers, once `gl` is known to serve it.
std::string RasterChoice(const EyeRayRequest& request, const GlContext& gl) {
    if (request.path == EyeRayPath::kRaster) return "--eye-rays raster";
    if (request.RasterAsked()) return "auto: raster for " + request.rasterOption;
    return "auto: raster on hardware OpenGL (" + gl.Renderer() + ")";
}

}  // namespace

EyeRays ChooseEyeRays(const EyeRayRequest& request, render::RayEncoding encoding,
                      const scene::Scene& scene, std::ostream& err,
                      const std::function<void()>& beforeOpenGl) {
    if (request.path == EyeRayPath::kKernel) return {nullptr, "--eye-rays kernel"};
    if (encoding == render::RayEncoding::kPolar16) {
        return {nullptr, "auto: kernel for --ray-encoding polar16"};
    }
    const bool asked = request.RasterAsked();
    if (!asked && OnlySoftwareEglDevices()) {
        return {nullptr, "auto: kernel, software OpenGL only (EGL_MESA_device_software)"};
    }
    beforeOpenGl();
    std::string why;
    GlContext* gl = GlContext::Shared(&why);
    if (!gl) {
        if (asked) throw GlError(why);
        err << "rayclass: no OpenGL context, eye rays by kernel (" << why << ")\n";
        return {nullptr, "auto: kernel, no OpenGL context"};
    }
    if (!asked && IsSoftwareRenderer(gl->Renderer())) {
        return {nullptr, "auto: kernel, software OpenGL (" + gl->Renderer() + ")"};
    }
    for (const std::string& warning : DepthWarnings(scene, scene.camera.position, request.raster)) {
        err << "rayclass: warning: " << warning << "\n";
    }
    return {std::make_unique<RasterEyeHits>(*gl, request.raster), RasterChoice(request, *gl)};
}

}  // namespace rayclass::raster
