// classify_bench SCENE.obj [options]: ray-classification statistics for the anchor camera's eye
// rays and one generation of mirror rays (fresh hierarchy, and inserted into the eye rays'
// hierarchy). Times are one thread.
//
//   --width W --height H   eye-ray image size (1024 x 768)
//   --repeat N             classifications timed per generation; the median counts (5)
//   --split midpoint|median, --min-rays N, --min-cand N, --splits-per-list N, --dir-weight W
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "rayclass/classify/query.h"
#include "rayclass/classify/stats.h"

namespace {

using namespace rayclass;

// TEMPORARY: a minimal reader of `v` and `f` lines (polygons fan-triangulated, negative indices
// allowed), until rayclass::scene::LoadScene (include/rayclass/scene/loader.h) is merged.
scene::Scene ReadObjTriangles(const std::string& path) {
    std::ifstream in(path);
    if (!in) {
        std::fprintf(stderr, "cannot open %s\n", path.c_str());
        std::exit(1);
    }
    scene::Scene s;
    std::vector<glm::vec3> v;
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream ls(line);
        std::string tag;
        ls >> tag;
        if (tag == "v") {
            glm::vec3 p;
            ls >> p.x >> p.y >> p.z;
            v.push_back(p);
        } else if (tag == "f") {
            std::vector<int> idx;
            std::string tok;
            while (ls >> tok) {
                const int i = std::stoi(tok.substr(0, tok.find('/')));
                idx.push_back(i < 0 ? int(v.size()) + i : i - 1);
            }
            for (size_t k = 2; k < idx.size(); ++k) {
                scene::Triangle t;
                t.p = {v[size_t(idx[0])], v[size_t(idx[k - 1])], v[size_t(idx[k])]};
                s.triangles.push_back(t);
            }
        }
    }
    return s;
}

void Print(const char* name, const classify::ClassifyStats& s) {
    std::printf(
        "%-14s rays %8u  missed %6u  leaves %7u  nodes %7u  depth %2u  cand/ray %7.1f (max %6u)  "
        "tests/ray %7.2f (brute force %u)  box tests/ray %6.1f  moves/ray %5.1f  "
        "classify %6.1f ns/ray  host query %7.1f ns/ray  hierarchy %6.1f MiB  leaves %6.1f MiB  "
        "peak RSS %7.1f MiB\n",
        name, s.nRays, s.nMissed, s.nLeaves, s.nNodes, s.maxDepth, s.avgCandidates,
        s.maxCandidates, s.testsPerRay, s.bruteForceTests, s.boxTestsPerRay, s.rayMovesPerRay,
        s.classifyNsPerRay, s.queryNsPerRay, double(s.hierarchyBytes) / 1048576.0,
        double(s.leafBytes) / 1048576.0, double(s.peakRssBytes) / 1048576.0);
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: %s SCENE.obj [--width W] [--height H] [--repeat N] "
                             "[--split midpoint|median] [--min-rays N] [--min-cand N] "
                             "[--splits-per-list N] [--dir-weight W]\n", argv[0]);
        return 2;
    }
    uint32_t width = 1024, height = 768;
    int repeat = 5;
    const scene::Scene scene = ReadObjTriangles(argv[1]);
    classify::Params params = classify::Params::ForScene(scene);
    for (int i = 2; i + 1 < argc; i += 2) {
        const std::string opt = argv[i], val = argv[i + 1];
        if (opt == "--width") width = uint32_t(std::stoul(val));
        else if (opt == "--height") height = uint32_t(std::stoul(val));
        else if (opt == "--repeat") repeat = std::stoi(val);
        else if (opt == "--split") params.splitRule = val == "median" ? classify::SplitRule::kMedian : classify::SplitRule::kMidpoint;
        else if (opt == "--min-rays") params.minRays = uint32_t(std::stoul(val));
        else if (opt == "--min-cand") params.minCandidates = uint32_t(std::stoul(val));
        else if (opt == "--splits-per-list") params.splitsPerList = std::stoi(val);
        else if (opt == "--dir-weight") params.dirWeight = std::stof(val);
        else {
            std::fprintf(stderr, "unknown option %s\n", opt.c_str());
            return 2;
        }
    }
    std::printf("%s: %u triangles, %ux%u eye rays, %d repeats\n", argv[1], scene.PrimitiveCount(),
                width, height, repeat);

    const auto eye = classify::AnchorEyeRays(scene, width, height);
    std::vector<geometry::Hit<float>> eyeHits(eye.size());
    const auto eyeStats = classify::ComputeStats(scene, eye, params, repeat, eyeHits);
    Print("eye", eyeStats);
    std::printf("%-14s setup (presorted face lists) %.1f ms\n", "", eyeStats.setupMs);

    const auto mirror = classify::MirrorRays(scene, eye, eyeHits);
    Print("mirror", classify::ComputeStats(scene, mirror, params, repeat));

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
    return 0;
}
