#include <charconv>
#include <nlohmann/json.hpp>
#include <ostream>

#include "rayclass/classify/stats.h"
#include "rayclass/cli/cli.h"
#include "rayclass/core/error.h"
#include "rayclass/render/device_scene.h"
#include "rayclass/scene/loader.h"

namespace rayclass::cli {

namespace {

constexpr const char* kUsage = R"(usage: rayclass classify-stats SCENE [options]

Classifies one generation of eye rays and one generation of mirror rays (one bounce off every eye
hit) and prints what the ray-classification hierarchy looks like and what it costs; then the eye
rays again as the renderer classifies them, from their camera (eye_from_camera; absent when the
camera lies too far from the scene).

options:
  --width W, --height H   eye-ray resolution (default 1024x768)
  --camera scene|anchor   the scene's camera, or the benchmark camera of
                          design/notes/measured-anchors.md (default: scene for .json, anchor
                          for .obj)
  --repeat N              classify N times, report the median time (default 3)
  --classify NAME=VALUE   a cost-function setting (see 'rayclass render --help'), repeatable
  --json                  one JSON object instead of key: value lines
)";

uint32_t ParseCount(const std::string& option, const std::string& text, uint32_t hi) {
    uint32_t v = 0;
    auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
    if (ec != std::errc() || ptr != text.data() + text.size() || v < 1 || v > hi) {
        throw UsageError(option + " expects an integer in [1, " + std::to_string(hi) + "], not '" +
                         text + "'");
    }
    return v;
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

}  // namespace

int ClassifyStatsCommand(const std::vector<std::string>& args, std::ostream& out,
                         std::ostream& /*err*/) {
    std::string file, camera;
    uint32_t width = 1024, height = 768, repeat = 3;
    bool json = false;
    std::vector<std::pair<std::string, std::string>> settings;
    for (size_t i = 0; i < args.size(); ++i) {
        const std::string& a = args[i];
        auto value = [&]() -> const std::string& {
            if (i + 1 >= args.size()) throw UsageError(a + " needs a value");
            return args[++i];
        };
        if (a == "--help" || a == "-h") {
            out << kUsage;
            return 0;
        } else if (a == "--width") {
            width = ParseCount(a, value(), 16384);
        } else if (a == "--height") {
            height = ParseCount(a, value(), 16384);
        } else if (a == "--repeat") {
            repeat = ParseCount(a, value(), 100);
        } else if (a == "--camera") {
            camera = value();
            if (camera != "scene" && camera != "anchor") {
                throw UsageError("--camera must be scene or anchor, not '" + camera + "'");
            }
        } else if (a == "--classify") {
            const std::string& setting = value();
            const auto eq = setting.find('=');
            if (eq == std::string::npos) {
                throw UsageError("--classify expects NAME=VALUE, not '" + setting + "'");
            }
            settings.emplace_back(setting.substr(0, eq), setting.substr(eq + 1));
        } else if (a == "--json") {
            json = true;
        } else if (!a.empty() && a[0] == '-') {
            throw UsageError("unknown option '" + a + "' (see 'rayclass classify-stats --help')");
        } else if (file.empty()) {
            file = a;
        } else {
            throw UsageError("unexpected argument '" + a + "'");
        }
    }
    if (file.empty()) throw UsageError("no scene given (see 'rayclass classify-stats --help')");
    scene::Scene scene = scene::LoadScene(file);
    if (camera.empty()) camera = file.ends_with(".json") ? "scene" : "anchor";
    scene.camera.width = width;
    scene.camera.height = height;
    const std::vector<classify::Ray> eye =
        camera == "anchor" ? classify::AnchorEyeRays(scene, width, height) : SceneEyeRays(scene);
    classify::Params params = classify::Params::ForScene(scene);
    for (const auto& [name, v] : settings) classify::SetParam(params, name, v);
    std::vector<geometry::Hit<float>> hits(eye.size());
    const auto eyeStats = classify::ComputeStats(scene, eye, params, int(repeat), hits);
    const std::vector<classify::Ray> mirror = classify::MirrorRays(scene, eye, hits);
    const auto mirrorStats = classify::ComputeStats(scene, mirror, params, int(repeat));
    // The same eye rays classified from their camera, as the renderer does when it can.
    const RcCamera rc = camera == "anchor" ? classify::AnchorCamera(scene, width, height)
                                           : render::CameraBasis(scene.camera).ToDevice();
    const auto cameraStats =
        classify::ComputeStats(scene, eye, params, int(repeat), {}, false, &rc);

    nlohmann::json j = {{"scene", file},
                        {"primitives", scene.PrimitiveCount()},
                        {"camera", camera},
                        {"width", width},
                        {"height", height},
                        {"eye", ToJson(eyeStats)},
                        {"mirror", ToJson(mirrorStats)}};
    const char* gens[] = {"eye", "mirror", "eye_from_camera"};
    if (cameraStats.classifiedFromCamera) j["eye_from_camera"] = ToJson(cameraStats);
    if (json) {
        out << j.dump(2) << "\n";
        return 0;
    }
    out << "scene: " << file << "\nprimitives: " << scene.PrimitiveCount() << "\ncamera: " << camera
        << " " << width << "x" << height << "\n";
    for (const char* gen : gens) {
        if (!j.contains(gen)) continue;
        for (const auto& [key, v] : j[gen].items()) out << gen << "." << key << ": " << v << "\n";
    }
    return 0;
}

}  // namespace rayclass::cli
