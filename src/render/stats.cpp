#include "rayclass/render/stats.h"

namespace rayclass::render {

uint64_t RenderStats::RaysTotal() const {
    uint64_t total = 0;
    for (const auto& [kind, n] : raysByKind) total += n;
    return total;
}

nlohmann::json RenderStats::ToJson() const {
    nlohmann::json j;
    j["width"] = width;
    j["height"] = height;
    if (part.frame) {
        j["frame"] = *part.frame;
        j["frame_time"] = part.frameTime;
    }
    if (part.tile) j["tile"] = {{"index", (*part.tile)[0]}, {"count", (*part.tile)[1]}};
    if (part.crop) j["crop"] = *part.crop;
    j["device"] = device;
    j["accel"] = accel;
    j["eye_rays"] = eyeRays;
    if (!eyeRaysChoice.empty()) j["eye_rays_choice"] = eyeRaysChoice;
    j["primitives"] = nPrimitives;
    j["scene_bytes"] = sceneBytes;
    j["program_from_cache"] = programFromCache;
    j["rays_total"] = RaysTotal();
    j["rays_by_kind"] = raysByKind;
    nlohmann::json gens = nlohmann::json::array();
    for (const auto& g : generations) {
        nlohmann::json gen = {{"rays", g.rays},
                              {"shadow_rays", g.shadowRays},
                              {"spawned", g.spawned},
                              {"seconds", g.seconds},
                              {"host_classify_seconds", g.hostClassifySeconds},
                              {"intersection_tests", g.intersectionTests},
                              {"query", g.query},
                              {"shadow_query", g.shadowQuery}};
        const std::pair<const char*, double> costs[] = {{"classified_predicted", g.classifiedNs},
                                                        {"bvh_sample", g.bvhSampleNs}};
        for (const auto& [name, ns] : costs) {
            if (ns > 0) gen["auto_ns_per_ray"][name] = ns;
        }
        gens.push_back(gen);
    }
    j["rays_by_generation"] = gens;
    j["intersection_tests"] = intersectionTests;
    j["shadow_rays_from_light"] = shadowRaysFromLight;
    j["shadow_rays_in_cells"] = shadowRaysInCells;
    j["eye_rays_from_camera"] = eyeRaysFromCamera;
    if (!accelStats.empty()) j["accel_stats"] = accelStats;
    if (!patchNewton.empty()) j["patch_newton"] = patchNewton;
    j["mrays_per_s"] = queryTimeS > 0 ? double(RaysTotal()) / queryTimeS * 1e-6 : 0.0;
    j["time_s"] = timeS;
    return j;
}

}  // namespace rayclass::render
