// The ray workloads of scripts/bench, shared by the rayclass throughput program
// (bench/raybench) and the Embree baseline (bench/embree): named cameras, eye rays by the RcCamera
// formula in float, and the secondary rays of one bounce generated from the eye rays' hits.
// raybench finds the hits (BVH query on the device, identical to brute force), generates every
// set and saves them to a file that embree_bench reads, so both shoot exactly the same rays.
#pragma once

#include <cstdint>
#include <filesystem>
#include <glm/glm.hpp>
#include <string>
#include <vector>

#include "rayclass/scene/scene.h"

namespace rayclass::bench {

// A ray for the benchmarks: origin, tMin, unit direction, tMax (INFINITY for nearest-hit kinds,
// the distance to the light for shadow rays). 32 bytes.
struct BenchRay {
    glm::vec3 origin{0.0f};
    float tMin = 0.0f;
    glm::vec3 direction{0.0f, 0.0f, 1.0f};
    float tMax = 0.0f;
};
static_assert(sizeof(BenchRay) == 32);

// Ray kinds in file order. Every kind but "eye" starts at the eye rays' hits: shadow (to the
// light, any hit), reflection (mirror about the geometric normal), refraction (every surface taken
// as glass of ior 1.5; total internal reflection spawns none), diffuse (one cosine-distributed
// direction about the geometric normal, fixed seed).
inline const char* const kKinds[] = {"eye", "shadow", "reflection", "refraction", "diffuse"};
constexpr int kNumKinds = 5;
inline bool IsShadowKind(int kind) { return kind == 1; }

// Each ray's pixel (y * width + x of the eye ray it descends from), so a peer can lay every set
// out in the same pixel-tile order.
struct RaySets {
    uint32_t width = 0;
    std::vector<BenchRay> sets[kNumKinds];
    std::vector<uint32_t> pixels[kNumKinds];
};

// Named cameras: "scene" (the scene's own; a bare OBJ's framing camera), "orbit" (the scene
// camera turned 40 degrees about its look-at point around +y), "anchor" (the benchmark camera of
// scenes/bench: eye = box centre - 0.25 size_x (1,0,0), along +x, up +y, 60 degrees) and
// "reverse" (anchor mirrored: eye = centre + 0.25 size_x (1,0,0) + 0.1 size_y (0,1,0), along -x).
// Throws std::invalid_argument for an unknown name.
scene::Camera NamedCamera(const scene::Scene& scene, const std::string& name, uint32_t width,
                          uint32_t height);

// Light position: "scene" (the scene's first light) or "anchor:F" (box centre + F size_y (0,1,0)).
glm::vec3 NamedLight(const scene::Scene& scene, const std::string& spec);

// Eye rays of `camera`, row 0 at the top, by RcCamera's float formula.
std::vector<BenchRay> EyeRays(const scene::Camera& camera);

// Nearest hit of each eye ray (prim == 0xFFFFFFFF: miss), with RcHit's u, v (a triangle's
// barycentrics, a patch box's local parameters: its normal depends on them).
struct BenchHit {
    float t;
    uint32_t prim;
    float u = 0.0f, v = 0.0f;
};

// The secondary sets from the eye rays' hits. Origins are the hit point moved 1e-4 of the scene
// box's diagonal along the geometric normal (to the side the ray leaves towards), tMin 0.
// `eye` holds the rays of an image `width` pixels wide, row by row.
RaySets MakeRaySets(const scene::Scene& scene, const std::vector<BenchRay>& eye,
                    const std::vector<BenchHit>& hits, const glm::vec3& light, uint32_t seed,
                    uint32_t width);

// Binary file of the five sets: "RCRAYS2\0", the uint32 width, five uint64 counts, the rays, then
// their pixels.
void SaveRaySets(const std::filesystem::path& file, const RaySets& sets);
RaySets LoadRaySets(const std::filesystem::path& file);

}  // namespace rayclass::bench
