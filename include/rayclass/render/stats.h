// Counters and timings of one render, written by --stats as JSON.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace rayclass::render {

struct GenerationStats {
    uint64_t rays = 0;        // rays queried for their nearest hit (eye, reflection, refraction)
    uint64_t shadowRays = 0;  // shadow rays queried
    uint64_t spawned = 0;     // secondary rays this generation spawned for the next
    double seconds = 0;       // wall time from its first batch to its last
    double hostClassifySeconds = 0;  // of it, the classification's host work (all threads)
    uint64_t intersectionTests = 0;  // primitive tests of its nearest-hit and shadow queries
    // What answered its nearest-hit and shadow queries (RayQuery::Name(), or what auto chose).
    std::string query, shadowQuery;
    // --accel auto: the costs per ray (ns; process CPU time on a CPU device, auto_query.h) of
    // nearest-hit queries its choice compared, the classification's as predicted; 0: not
    // measured.
    double classifiedNs = 0, bvhSampleNs = 0;
};

// Which part of an animation and of its image a render is (rayclass render --frame, --tile,
// --crop).
struct RenderPart {
    std::optional<uint32_t> frame;
    double frameTime = 0;                         // the frame's time on the camera path
    std::optional<std::array<uint32_t, 2>> tile;  // index, count
    std::optional<std::array<uint32_t, 4>> crop;  // x0, y0, x1, y1 of a crop or tile
};

struct RenderStats {
    uint32_t width = 0, height = 0;  // of the whole image, also for a crop
    RenderPart part;
    std::string device;
    std::string accel = "brute";
    std::string eyeRays = "kernel";  // who found the eye rays' first hits: kernel or raster
    std::string eyeRaysChoice;       // why (rayclass render --eye-rays); empty: not recorded
    uint64_t nPrimitives = 0;
    uint64_t sceneBytes = 0;  // SceneBuffers::GeometryBytes
    std::map<std::string, uint64_t> raysByKind{
        {"eye", 0}, {"shadow", 0}, {"reflection", 0}, {"refraction", 0}};
    std::vector<GenerationStats> generations;
    uint64_t intersectionTests = 0;
    uint64_t shadowRaysFromLight = 0;  // classified from their light (classify::CommonEnds)
    uint64_t shadowRaysInCells = 0;    // of them, sorted into direction cells (light_cells.h)
    uint64_t eyeRaysFromCamera = 0;    // classified from their camera (ClassifyPinhole)
    std::map<std::string, double> accelStats;  // the query's own figures (QueryStats::accel)
    std::map<std::string, double> patchNewton;  // NewtonCounts::ToStats (render/newton_stats.h)
    bool programFromCache = false;     // the kernels' binary came from the program cache
    double queryTimeS = 0;             // time of the ray-query kernels (nearest hit and shadow)
    // Named stages in seconds: "scene_load", "program_build", "kernel_<name>", "host", "total".
    std::map<std::string, double> timeS;

    uint64_t RaysTotal() const;
    nlohmann::json ToJson() const;
};

}  // namespace rayclass::render
