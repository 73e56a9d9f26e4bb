// Shared pieces of the raster tests: one GL context and one OpenCL context per binary, the
// kernel path's eye-ray hits, and hit-buffer comparison.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "rayclass/clrt/context.h"
#include "rayclass/raster/raster_pass.h"
#include "rayclass/render/brute_query.h"
#include "rayclass/scene/scene.h"
#include "test_device.h"

namespace rayclass::raster::testing_support {

inline std::filesystem::path SceneDir() {
    const char* source = std::getenv("RAYCLASS_SOURCE_DIR");
    return std::filesystem::path(source ? source : ".") / "scenes";
}

// The process's GL context, or nullptr when none can be made (tests then skip).
inline GlContext* Gl() {
    std::string why;
    GlContext* gl = GlContext::Shared(&why);
    if (!gl) std::fprintf(stderr, "no OpenGL context: %s\n", why.c_str());
    return gl;
}

#define RC_REQUIRE_GL()                                        \
    GlContext* gl = ::rayclass::raster::testing_support::Gl(); \
    if (!gl) GTEST_SKIP() << "no headless OpenGL context";

inline clrt::Context& Cl() {
    static clrt::Context ctx(TestDeviceSpec());
    return ctx;
}

// The kernel path: rc_generate_eye_rays, then rc_intersect_brute, for every pixel.
inline std::vector<RcHit> KernelHits(const scene::Scene& scene) {
    static const cl::Program program = render::BuildRenderProgram(Cl());
    RcRenderParams params{};
    params.nTriangles = uint32_t(scene.triangles.size());
    params.nSpheres = uint32_t(scene.spheres.size());
    params.nQuadrics = render::AnalyticRecords(scene);
    const render::SceneBuffers buffers(Cl(), scene, params);
    auto query = render::MakeBruteForceQuery(Cl(), program, buffers);
    const RcCamera cam = render::CameraBasis(scene.camera).ToDevice();
    const uint32_t n = cam.width * cam.height;
    cl::Buffer camBuffer(Cl().context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof cam,
                         const_cast<RcCamera*>(&cam));
    cl::Buffer rays(Cl().context(), CL_MEM_READ_WRITE, n * sizeof(RcRay));
    cl::Buffer hits(Cl().context(), CL_MEM_READ_WRITE, n * sizeof(RcHit));
    cl::Kernel eye(program, "rc_generate_eye_rays");
    eye.setArg(0, camBuffer);
    eye.setArg(1, 0u);
    eye.setArg(2, n);
    eye.setArg(3, rays);
    Cl().queue().enqueueNDRangeKernel(eye, cl::NullRange, cl::NDRange(clrt::RoundUp(n, 64)),
                                      cl::NDRange(64));
    render::KernelTimer timer;
    // Brute force shades nothing itself: the shading buffers stay unused.
    query->Intersect(rays, n, nullptr, hits, render::ShadeBuffers{}, timer);
    std::vector<RcHit> out(n);
    Cl().queue().enqueueReadBuffer(hits, CL_TRUE, 0, n * sizeof(RcHit), out.data());
    return out;
}

struct HitComparison {
    size_t pixels = 0;
    size_t idMismatch = 0;  // different primitive (or hit vs miss)
    size_t tDiffer = 0;     // same primitive, different t bits
    size_t uvDiffer = 0;    // same triangle, different barycentrics
    size_t missVsHit = 0;   // one path hit, the other missed
    double maxRelTGap = 0;  // over id mismatches with two hits: |t_a - t_b| / t_b
    std::vector<size_t> mismatchPixels;
};

inline HitComparison CompareHits(const std::vector<RcHit>& a, const std::vector<RcHit>& b) {
    HitComparison c;
    c.pixels = a.size();
    for (size_t i = 0; i < a.size() && i < b.size(); ++i) {
        if (a[i].prim != b[i].prim) {
            ++c.idMismatch;
            c.mismatchPixels.push_back(i);
            if (a[i].prim == RC_NO_HIT || b[i].prim == RC_NO_HIT) {
                ++c.missVsHit;
            } else {
                c.maxRelTGap = std::max(c.maxRelTGap, double(std::abs(a[i].t - b[i].t)) / b[i].t);
            }
        } else if (a[i].prim != RC_NO_HIT) {
            if (a[i].t != b[i].t) ++c.tDiffer;
            if (a[i].u != b[i].u || a[i].v != b[i].v) ++c.uvDiffer;
        }
    }
    return c;
}

}  // namespace rayclass::raster::testing_support
