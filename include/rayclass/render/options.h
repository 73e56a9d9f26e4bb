// What a render is asked to do, independent of which renderer does it.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace rayclass::render {

struct RenderOptions {
    uint32_t maxDepth = 6;          // deepest secondary ray spawned (eye rays have depth 0)
    float minWeight = 1e-3f;        // adaptive depth control: weaker secondary rays are not spawned
    bool aovs = false;              // fill depth, id and normal layers of the first hit
    // Rays per batch: bounds the device buffers (launch.h's BatchRays also keeps them within
    // one device allocation); a generation of several batches lets the host classify one while
    // the device answers another. Yet each batch descends the hierarchy anew and filters the
    // lists of every node it visits, so a whole 1024x768 generation in one batch filters far
    // fewer boxes and renders deep mirror scenes faster with --accel classify, for more memory.
    // Where classifying is cheap, the larger buffers' page faults cost more than it saves (very
    // large images of simple scenes).
    uint32_t batchRays = 1u << 20;
    std::string device = "auto";    // OpenCL device: auto, cpu, gpu or an index
    // Ray query: classify (ray classification), bvh, auto (auto_query.h) or brute.
    std::string accel = "classify";
    // Cost-function settings of the classification (classify::SetParam names and values).
    std::vector<std::pair<std::string, std::string>> classifyParams;
    std::string kernel = "auto";        // classified query style: scalar, vertex, fragment, auto
    std::string buildOptions;           // extra OpenCL build options
    std::string rayEncoding = "float";  // ray directions: float or polar16 (cl/encoding.cl)
    bool progress = true;               // progress line on stderr for renders over a second
    std::string eyeRays = "kernel";     // first hits of eye rays: "kernel" (ray query) or "raster"
    std::string hull = "auto";  // raster hulls of spheres/quadrics: sphere|box|billboard|auto
    // Ray/triangle test: moller (Moeller-Trumbore, default) or watertight (Woop, Benthin & Wald
    // 2013). Watertight applies to the brute-force and scalar classified kernels and the reference
    // renderer; the 16-lane vertex/fragment kernels are Moeller only, so with watertight the
    // classified query runs the scalar kernels (auto) and --kernel vertex|fragment is an error.
    std::string triangleTest = "moller";
};

}  // namespace rayclass::render
