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
    // lists of every node it visits: a 1024x768 generation in one batch filtered 43 % fewer
    // boxes than in three of 2^18 on sibenik_mirror (3.1 against 5.4 billion), and with
    // --accel classify rendered in 5.7-6.0 s against 7.0-8.1 s (conference_mirror 8.6-10.3
    // against 12.0-12.4 s; auto within the noise or faster, bvh up to 10 % slower), for 50 %
    // more memory (1.77 against 1.20 GB). Where classifying is cheap, the larger buffers'
    // page faults cost more than it saves: cornell.json at 4096x4096 took 6.7-8.0 s in batches
    // of 2^18 and 7.7-8.4 s in batches of 2^20, which fault in 0.6 GB more.
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
