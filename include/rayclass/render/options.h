// What a render is asked to do, independent of which renderer does it.
#pragma once

#include <cstdint>
#include <string>

namespace rayclass::render {

struct RenderOptions {
    uint32_t maxDepth = 6;     // deepest secondary ray spawned (eye rays have depth 0)
    float minWeight = 1e-3f;   // adaptive depth control: weaker secondary rays are not spawned
    bool aovs = false;         // fill depth, id and normal layers of the first hit
    uint32_t batchRays = 1u << 20;  // rays per kernel launch (bounds device buffers)
    std::string device = "auto";    // OpenCL device: auto, cpu, gpu or an index
    std::string accel = "classify";  // ray query: classify (ray classification) or brute
    std::string kernel = "auto";     // classified query style: scalar, vertex, fragment, auto
    // Ray/triangle test: moller (Moeller-Trumbore, default) or watertight (Woop, Benthin & Wald
    // 2013). Watertight applies to the brute-force and scalar classified kernels and the reference
    // renderer; the 16-lane vertex/fragment kernels are Moeller only, so with watertight the
    // classified query runs the scalar kernels (auto) and --kernel vertex|fragment is an error.
    std::string triangleTest = "moller";
    std::string buildOptions;       // extra OpenCL build options
    bool progress = true;           // progress line on stderr for renders over a second
};

}  // namespace rayclass::render
