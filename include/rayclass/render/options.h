// What a render is asked to do, independent of which renderer does it. Every choice is a typed
// value here; the command line turns its words into them once, through the name tables below,
// which --stats and the help texts share.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "rayclass/classify/params.h"
#include "rayclass/geometry/intersect.h"
#include "rayclass/image/tiles.h"

namespace rayclass::render {

// A choice's name, as the command line and --stats spell it.
template <typename E>
struct Named {
    std::string_view name;
    E value;
};

// The value `name` names in `names`, if any.
template <typename E, size_t N>
constexpr std::optional<E> FindChoice(const Named<E> (&names)[N], std::string_view name) {
    for (const Named<E>& n : names) {
        if (n.name == name) return n.value;
    }
    return std::nullopt;
}

// The name of `value` in `names` (empty when it has none).
template <typename E, size_t N>
constexpr std::string_view NameOf(const Named<E> (&names)[N], E value) {
    for (const Named<E>& n : names) {
        if (n.value == value) return n.name;
    }
    return {};
}

// The ray query: the ray classification, a BVH, auto (per generation, auto_query.h), brute
// force, or one of the seed documents' structures: a SAH kd-tree (kdtree_query.h), a uniform
// grid (grid_query.h) or Szecsi's hierarchical ray engine (cones_query.h).
enum class Accel : uint8_t { kClassify, kBvh, kAuto, kBrute, kKdTree, kGrid, kCones };
inline constexpr Named<Accel> kAccels[] = {{"classify", Accel::kClassify}, {"bvh", Accel::kBvh},
                                           {"auto", Accel::kAuto},         {"brute", Accel::kBrute},
                                           {"kdtree", Accel::kKdTree},     {"grid", Accel::kGrid},
                                           {"cones", Accel::kCones}};

// The classified query's kernels (cl/classified.cl, classified_vertex.cl, classified_scalar.cl).
enum class KernelStyle : uint8_t {
    kScalar,    // one work-item per ray, one candidate at a time
    kVertex,    // one work-item per ray, 16 candidates per step (float16 lanes over candidates)
    kFragment,  // one work-item per 16 rays of a leaf, lockstep over candidates
    kAuto,      // per leaf: fragment for coherent leaves, vertex otherwise (shadow rays: fragment)
};
inline constexpr Named<KernelStyle> kKernelStyles[] = {{"scalar", KernelStyle::kScalar},
                                                       {"vertex", KernelStyle::kVertex},
                                                       {"fragment", KernelStyle::kFragment},
                                                       {"auto", KernelStyle::kAuto}};

// Ray directions on the device: float, or packed 16-bit polar angles (cl/encoding.cl).
enum class RayEncoding : uint8_t { kFloat, kPolar16 };
inline constexpr Named<RayEncoding> kRayEncodings[] = {{"float", RayEncoding::kFloat},
                                                       {"polar16", RayEncoding::kPolar16}};

using geometry::TriangleTest;
inline constexpr Named<TriangleTest> kTriangleTests[] = {{"moller", TriangleTest::kMoller},
                                                         {"watertight", TriangleTest::kWatertight}};

struct RenderOptions {
    uint32_t maxDepth = 6;    // deepest secondary ray spawned (eye rays have depth 0)
    float minWeight = 1e-3f;  // adaptive depth control: weaker secondary rays are not spawned
    bool aovs = false;        // fill depth, id and normal layers of the first hit
    // Rays per batch: bounds the device buffers (launch.h's BatchRays also keeps them within
    // one device allocation); a generation of several batches lets the host classify one while
    // the device answers another. Yet each batch descends the hierarchy anew and filters the
    // lists of every node it visits, so a whole 1024x768 generation in one batch filters far
    // fewer boxes and renders deep mirror scenes faster with --accel classify, for more memory.
    // Where classifying is cheap, the larger buffers' page faults cost more than it saves (very
    // large images of simple scenes). With the default --accel auto, which answers deep
    // generations with the BVH, those page faults weigh more than the filtering, and a
    // quarter of a 1024x768 generation per batch renders the bench scenes faster.
    uint32_t batchRays = 1u << 18;
    Accel accel = Accel::kAuto;
    std::vector<classify::ParamSetting> classifyParams;  // cost-function settings, in order
    KernelStyle kernel = KernelStyle::kAuto;
    std::string buildOptions;  // extra OpenCL build options
    RayEncoding rayEncoding = RayEncoding::kFloat;
    bool progress = true;  // progress line on stderr for renders over a second
    // Ray/triangle test: Moeller-Trumbore (default) or watertight (Woop, Benthin & Wald 2013).
    // Watertight applies to the brute-force and scalar classified kernels and the reference
    // renderer; the 16-lane vertex/fragment kernels are Moeller only, so with watertight the
    // classified query runs the scalar kernels (auto) and --kernel vertex|fragment is an error.
    TriangleTest triangleTest = TriangleTest::kMoller;
    // Only these pixels of the image (a crop or tile), each as the whole render has it.
    std::optional<image::PixelRect> window;
    // Count how the patch boxes' Newton iteration ends, on a sample of the rays
    // (render/newton_stats.h); --stats sets it.
    bool newtonStats = false;
};

}  // namespace rayclass::render
