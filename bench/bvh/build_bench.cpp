// Build time of the BVH over the benchmark scenes (scenes/bench): the binary SAH tree alone on one
// thread and on every core, and the whole chain a render runs on its worker thread (build,
// collapse to wide nodes, leaf blocks). Counters: the binary tree's nodes, its deepest leaf and
// its SAH cost (BuildParams' cost model, relative to one primitive test of a ray through the root
// box), so that a faster build shows whether it bought its speed with a worse tree.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <string>

#include "rayclass/bvh/bvh.h"
#include "rayclass/bvh/leaf_blocks.h"
#include "rayclass/scene/loader.h"

namespace {

using rayclass::scene::Scene;
namespace bvh = rayclass::bvh;

const Scene& BenchScene(const std::string& name) {
    static std::map<std::string, Scene> loaded;
    auto it = loaded.find(name);
    if (it == loaded.end()) {
        const auto file = std::filesystem::path(RAYCLASS_BENCH_SOURCE_DIR) / "scenes" / "bench" /
                          (name + ".json");
        it = loaded.emplace(name, rayclass::scene::LoadScene(file)).first;
    }
    return it->second;
}

float HalfArea(const rayclass::Bounds3f& b) {
    const glm::vec3 s = b.hi - b.lo;
    return s.x * s.y + s.y * s.z + s.z * s.x;
}

double SahCost(const bvh::Bvh& tree, const bvh::BuildParams& params) {
    double cost = 0;
    for (const bvh::BinaryNode& n : tree.nodes)
        cost += double(HalfArea(n.box)) * (n.count > 0 ? double(n.count) : params.traversalCost);
    return cost / double(HalfArea(tree.nodes[0].box));
}

void Report(benchmark::State& state, const bvh::Bvh& tree, const bvh::BuildParams& params) {
    state.counters["nodes"] = double(tree.nodes.size());
    state.counters["depth"] = double(tree.maxDepth);
    state.counters["sah"] = SahCost(tree, params);
}

void BinaryTree(benchmark::State& state, const char* scene, uint32_t threads) {
    const Scene& sc = BenchScene(scene);
    bvh::BuildParams params;
    params.threads = threads;
    bvh::Bvh tree;
    for (auto _ : state) {
        tree = bvh::Build(sc, params);
        benchmark::DoNotOptimize(tree.nodes.data());
    }
    Report(state, tree, params);
}

void BlockedTree(benchmark::State& state, const char* scene) {
    const Scene& sc = BenchScene(scene);
    const bvh::BuildParams params;
    for (auto _ : state) {
        const bvh::Bvh tree = bvh::Build(sc, params);
        const bvh::BlockedBvh blocked = bvh::BlockLeaves(bvh::Collapse(tree), tree.primIndex, sc);
        benchmark::DoNotOptimize(blocked.nodes.data());
    }
}

BENCHMARK_CAPTURE(BinaryTree, conference_1thread, "conference", 1)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BinaryTree, conference, "conference", 0)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BlockedTree, conference, "conference")
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BinaryTree, sibenik, "sibenik", 0)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
