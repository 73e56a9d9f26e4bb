#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "rayclass/classify/stats.h"
#include "rayclass/cli/cli.h"
#include "rayclass/cli/option_table.h"
#include "rayclass/core/error.h"
#include "rayclass/render/device_scene.h"
#include "rayclass/scene/loader.h"

namespace rayclass::cli {

namespace {

constexpr const char* kUsageHead = R"(usage: rayclass classify-stats SCENE [options]

Classifies one generation of eye rays and one generation of mirror rays (one bounce off every eye
hit) and prints what the ray-classification hierarchy looks like and what it costs; then the eye
rays again as the renderer classifies them, from their camera (eye_from_camera; absent when the
camera lies too far from the scene).

options:
)";

// The eye rays' camera: the scene's, or the benchmark camera (classify::AnchorCamera).
enum class Camera { kScene, kAnchor };
constexpr render::Named<Camera> kCameras[] = {{"scene", Camera::kScene},
                                              {"anchor", Camera::kAnchor}};

struct StatsArgs {
    std::string file;
    std::optional<Camera> camera;  // none: by the file's kind
    uint32_t width = 1024, height = 768, repeat = 3;
    bool json = false, help = false;
    // Parsed once the scene has loaded, so that a bad scene is reported first.
    std::vector<std::pair<std::string, std::string>> settings;
};

OptionTable StatsOptionTable(StatsArgs& a) {
    auto count = [](uint32_t& field, uint32_t hi) { return Number(field, 1u, hi, "an integer"); };
    return OptionTable(
        {
            {{"--width"}, "W", "", count(a.width, 16384)},
            {{"--height"}, "H", "eye-ray resolution (default 1024x768)", count(a.height, 16384)},
            {{"--camera"},
             "scene|anchor",
             "the scene's camera, or the benchmark camera of\n"
             "scenes/bench/README.md (default: scene for .json, anchor\n"
             "for .obj)",
             Choice(a.camera, kCameras)},
            {{"--repeat"},
             "N",
             "classify N times, report the median time (default 3)",
             count(a.repeat, 100)},
            {{"--classify"},
             "NAME=VALUE",
             "a cost-function setting (see 'rayclass render --help'), repeatable",
             [&a](const std::string& o, const std::string& v) {
                 a.settings.push_back(NameValue(o, v));
             }},
            {{"--json"}, "", "one JSON object instead of key: value lines", Flag(a.json)},
            {{},
             "",
             "",
             Flag(a.help),
             {"--help", "-h"},
             /*ends=*/true},
        },
        " (see 'rayclass classify-stats --help')");
}

StatsArgs ParseStatsArgs(const std::vector<std::string>& args) {
    StatsArgs a;
    StatsOptionTable(a).Parse(args, [&a](const std::string& arg) {
        if (!a.file.empty()) throw UsageError("unexpected argument '" + arg + "'");
        a.file = arg;
    });
    return a;
}

std::vector<classify::Ray> SceneEyeRays(const scene::Scene& scene) {
    const render::CameraBasis basis(scene.camera);
    std::vector<classify::Ray> rays;
    rays.reserve(size_t(basis.width) * basis.height);
    for (uint32_t y = 0; y < basis.height; ++y) {
        for (uint32_t x = 0; x < basis.width; ++x) {
            classify::Ray r;
            r.origin = glm::vec3(basis.position);
            r.direction = basis.DirectionFloat(x, y);
            rays.push_back(r);
        }
    }
    return rays;
}

nlohmann::json ToJson(const classify::ClassifyStats& s) {
    return {{"rays", s.nRays},
            {"rays_missing_scene_box", s.nMissed},
            {"leaves", s.nLeaves},
            {"nodes", s.nNodes},
            {"max_depth", s.maxDepth},
            {"avg_candidates_per_ray", s.avgCandidates},
            {"max_candidates_per_ray", s.maxCandidates},
            {"tests_per_ray", s.testsPerRay},
            {"brute_force_tests_per_ray", s.bruteForceTests},
            {"box_tests_per_ray", s.boxTestsPerRay},
            {"classify_ns_per_ray", s.classifyNsPerRay},
            {"host_query_ns_per_ray", s.queryNsPerRay},
            {"setup_ms", s.setupMs},
            {"hierarchy_bytes", s.hierarchyBytes},
            {"leaf_batch_bytes", s.leafBytes},
            {"peak_rss_bytes", s.peakRssBytes}};
}

// The statistics of `a`'s scene as one JSON object (see kUsageHead).
nlohmann::json Statistics(const StatsArgs& a) {
    if (a.file.empty()) throw UsageError("no scene given (see 'rayclass classify-stats --help')");
    scene::Scene scene = scene::LoadScene(a.file);
    const Camera camera =
        a.camera.value_or(a.file.ends_with(".json") ? Camera::kScene : Camera::kAnchor);
    const bool anchor = camera == Camera::kAnchor;
    scene.camera.width = a.width;
    scene.camera.height = a.height;
    const std::vector<classify::Ray> eye =
        anchor ? classify::AnchorEyeRays(scene, a.width, a.height) : SceneEyeRays(scene);
    classify::Params params = classify::Params::ForScene(scene);
    for (const auto& [name, v] : a.settings) classify::SetParam(params, name, v);
    const int repeat = int(a.repeat);
    std::vector<geometry::Hit<float>> hits(eye.size());
    const auto eyeStats = classify::ComputeStats(scene, eye, params, repeat, hits);
    const std::vector<classify::Ray> mirror = classify::MirrorRays(scene, eye, hits);
    const auto mirrorStats = classify::ComputeStats(scene, mirror, params, repeat);
    // The same eye rays classified from their camera, as the renderer does when it can.
    const RcCamera rc = anchor ? classify::AnchorCamera(scene, a.width, a.height)
                               : render::CameraBasis(scene.camera).ToDevice();
    const auto cameraStats = classify::ComputeStats(scene, eye, params, repeat, {}, false, &rc);

    nlohmann::json j = {{"scene", a.file},
                        {"primitives", scene.PrimitiveCount()},
                        {"camera", std::string(render::NameOf(kCameras, camera))},
                        {"width", a.width},
                        {"height", a.height},
                        {"eye", ToJson(eyeStats)},
                        {"mirror", ToJson(mirrorStats)}};
    if (cameraStats.classifiedFromCamera) j["eye_from_camera"] = ToJson(cameraStats);
    return j;
}

// `j` as key: value lines, a generation's keys prefixed with its name.
void PrintText(const nlohmann::json& j, std::ostream& out) {
    out << "scene: " << j["scene"].get<std::string>() << "\nprimitives: " << j["primitives"]
        << "\ncamera: " << j["camera"].get<std::string>() << " " << j["width"] << "x" << j["height"]
        << "\n";
    for (const char* gen : {"eye", "mirror", "eye_from_camera"}) {
        if (!j.contains(gen)) continue;
        for (const auto& [key, v] : j[gen].items()) out << gen << "." << key << ": " << v << "\n";
    }
}

}  // namespace

int ClassifyStatsCommand(const std::vector<std::string>& args, std::ostream& out,
                         std::ostream& /*err*/) {
    const StatsArgs a = ParseStatsArgs(args);
    if (a.help) {
        StatsArgs unused;
        out << kUsageHead << StatsOptionTable(unused).Help(24);
        return 0;
    }
    const nlohmann::json j = Statistics(a);
    if (a.json) {
        out << j.dump(2) << "\n";
    } else {
        PrintText(j, out);
    }
    return 0;
}

}  // namespace rayclass::cli
