// classify_bench SCENE [options]: ray-classification statistics for the anchor camera's eye rays
// (bench/common/raysets.h), one generation of mirror rays and one of shadow rays from
// the eye hits to the anchor light (any-hit query), each in a fresh hierarchy, and the mirror
// generation inserted into the eye rays' hierarchy. Times are the calling thread's (wall and CPU);
// the classification runs on every core, the host query on one. SCENE is anything
// rayclass::scene::LoadScene reads (.obj or .json).
//
//   --width W --height H   eye-ray image size (1024 x 768)
//   --repeat N             classifications timed per generation; the median counts (5)
//   --gen LIST             generations to run, comma-separated: eye,pinhole,mirror,shadow,shared
//                          (all; pinhole: the eye rays by Hierarchy::ClassifyPinhole)
//   --bounces N            mirror generations: the mirror rays of the previous one's hits, each in
//                          a fresh hierarchy, printed as "mirror 2", "mirror 3", ... (1). Later
//                          bounces are less coherent: their lists filter ever longer.
//   --light-f F            shadow light at box centre + F size_y (0, 1, 0) (0.1, sibenik's)
//   --param NAME=VALUE     any classify::SetParam parameter (min-rays, min-candidates, ...)
//   --split midpoint|median, --min-rays N, --min-cand N, --splits-per-list N, --dir-weight W
//                          shorthands for --param
#include <cstdio>
#include <cstdlib>
#include <string>

#include "rayclass/classify/query.h"
#include "rayclass/classify/stats.h"
#include "rayclass/core/error.h"
#include "rayclass/scene/loader.h"

namespace {

using namespace rayclass;

void Print(const char* name, const classify::ClassifyStats& s) {
    std::printf(
        "%-14s rays %8u  missed %6u  leaves %7u  nodes %7u  depth %2u  cand/ray %7.1f (max %6u)  "
        "tests/ray %7.2f (brute force %u)  box tests/ray %6.1f  moves/ray %5.1f  "
        "classify %6.1f ns/ray (cpu %6.1f)  host query %7.1f ns/ray  hierarchy %6.1f MiB  leaves %6.1f MiB  "
        "peak RSS %7.1f MiB\n",
        name, s.nRays, s.nMissed, s.nLeaves, s.nNodes, s.maxDepth, s.avgCandidates,
        s.maxCandidates, s.testsPerRay, s.bruteForceTests, s.boxTestsPerRay, s.rayMovesPerRay,
        s.classifyNsPerRay, s.classifyCpuNsPerRay, s.queryNsPerRay, double(s.hierarchyBytes) / 1048576.0,
        double(s.leafBytes) / 1048576.0, double(s.peakRssBytes) / 1048576.0);
    std::fflush(stdout);
}

bool Wants(const std::string& gens, const std::string& gen) {
    size_t at = 0;
    while (at <= gens.size()) {
        size_t end = gens.find(',', at);
        if (end == std::string::npos) end = gens.size();
        if (gens.compare(at, end - at, gen) == 0) return true;
        at = end + 1;
    }
    return false;
}

int Run(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr,
                     "usage: %s SCENE [--width W] [--height H] [--repeat N] "
                     "[--gen eye,pinhole,mirror,shadow,shared] [--light-f F] "
                     "[--param NAME=VALUE]... (names: %s)\n",
                     argv[0], classify::ParamNames());
        return 2;
    }
    uint32_t width = 1024, height = 768;
    int repeat = 5;
    float lightF = 0.1f;
    std::string gens = "eye,pinhole,mirror,shadow,shared";
    int bounces = 1;
    const scene::Scene scene = scene::LoadScene(argv[1]);
    classify::Params params = classify::Params::ForScene(scene);
    for (int i = 2; i + 1 < argc; i += 2) {
        const std::string opt = argv[i], val = argv[i + 1];
        if (opt == "--width") width = uint32_t(std::stoul(val));
        else if (opt == "--height") height = uint32_t(std::stoul(val));
        else if (opt == "--repeat") repeat = std::stoi(val);
        else if (opt == "--gen") gens = val;
        else if (opt == "--bounces")
            bounces = std::stoi(val);
        else if (opt == "--light-f") lightF = std::stof(val);
        else if (opt == "--param") {
            const size_t eq = val.find('=');
            if (eq == std::string::npos) throw UsageError("--param wants NAME=VALUE, got " + val);
            classify::SetParam(params, val.substr(0, eq), val.substr(eq + 1));
        }
        else if (opt == "--split") classify::SetParam(params, "split", val);
        else if (opt == "--min-rays") classify::SetParam(params, "min-rays", val);
        else if (opt == "--min-cand") classify::SetParam(params, "min-candidates", val);
        else if (opt == "--splits-per-list") classify::SetParam(params, "splits-per-list", val);
        else if (opt == "--dir-weight") classify::SetParam(params, "dir-weight", val);
        else throw UsageError("unknown option " + opt);
    }
    std::printf("%s: %u triangles, %ux%u eye rays, %d repeats\n", argv[1], scene.PrimitiveCount(),
                width, height, repeat);

    const auto eye = classify::AnchorEyeRays(scene, width, height);
    std::vector<geometry::Hit<float>> eyeHits(eye.size());
    // The later generations start from the eye hits, so the eye rays are always classified.
    const auto eyeStats = classify::ComputeStats(scene, eye, params,
                                                 Wants(gens, "eye") ? repeat : 1, eyeHits);
    if (Wants(gens, "eye")) {
        Print("eye", eyeStats);
        std::printf("%-14s setup (presorted face lists) %.1f ms\n", "", eyeStats.setupMs);
    }

    if (Wants(gens, "pinhole")) {
        // The same eye rays classified by image rectangles; their host hits must match.
        const RcCamera camera = classify::AnchorCamera(scene, width, height);
        std::vector<geometry::Hit<float>> hits(eye.size());
        const auto stats = classify::ComputeStats(scene, eye, params, repeat, hits, false, &camera);
        if (!stats.classifiedFromCamera)
            throw Error("the pinhole classification refused the camera");
        Print("eye pinhole", stats);
        size_t differ = 0;
        for (size_t i = 0; i < eye.size(); ++i) {
            differ += hits[i].prim != eyeHits[i].prim || hits[i].t != eyeHits[i].t;
        }
        std::printf("%-14s hits differing from the eye rays' classification: %zu\n", "", differ);
    }

    const auto mirror = classify::MirrorRays(scene, eye, eyeHits);
    if (Wants(gens, "mirror")) {
        std::vector<geometry::Hit<float>> hits(mirror.size());
        Print("mirror", classify::ComputeStats(scene, mirror, params, repeat, hits));
        auto rays = mirror;
        for (int b = 2; b <= bounces; ++b) {
            rays = classify::MirrorRays(scene, rays, hits);
            hits.assign(rays.size(), {});
            const std::string name = "mirror " + std::to_string(b);
            Print(name.c_str(), classify::ComputeStats(scene, rays, params, repeat, hits));
        }
    }

    if (Wants(gens, "shadow")) {
        const glm::vec3 light = classify::AnchorLight(scene, lightF);
        const auto shadow =
            classify::ShadowRays(eye, eyeHits, light, 1e-4f * scene.Bounds().Diagonal());
        Print("shadow", classify::ComputeStats(scene, shadow, params, repeat, {}, true));
    }

    if (Wants(gens, "shared")) {
        // The mirror generation inserted into the hierarchy the eye rays built (remainder sets).
        classify::Hierarchy shared(scene, params);
        shared.Classify(eye);
        const auto nodesBefore = shared.Nodes().size();
        const auto batch = shared.Classify(mirror);
        std::vector<geometry::Hit<float>> hits(mirror.size());
        const uint64_t tests = classify::QueryHost(scene, batch, mirror, hits);
        std::printf("%-14s leaves %u  new nodes %zu  tests/ray %.2f\n", "mirror shared",
                    uint32_t(batch.leaves.size()), shared.Nodes().size() - nodesBefore,
                    double(tests) / double(std::max<size_t>(mirror.size(), 1)));
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    try {
        return Run(argc, argv);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "classify_bench: %s\n", e.what());
        return 1;
    }
}
