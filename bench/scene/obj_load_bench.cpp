// Load time of the benchmark meshes (scenes/bench).
#include <benchmark/benchmark.h>

#include <filesystem>

#include "rayclass/scene/obj.h"

namespace {

void LoadObjFile(benchmark::State& state, const char* name) {
    const std::filesystem::path file =
        std::filesystem::path(RAYCLASS_BENCH_SOURCE_DIR) / "scenes" / "bench" / name;
    size_t triangles = 0;
    for (auto _ : state) {
        const rayclass::scene::ObjMesh mesh = rayclass::scene::LoadObj(file);
        triangles = mesh.triangles.size();
        benchmark::DoNotOptimize(triangles);
    }
    state.counters["triangles"] = double(triangles);
    state.SetBytesProcessed(int64_t(state.iterations()) *
                            int64_t(std::filesystem::file_size(file)));
}

BENCHMARK_CAPTURE(LoadObjFile, conference, "conference.obj")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(LoadObjFile, sibenik, "sibenik.obj")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(LoadObjFile, bunny, "bunny.obj")->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
