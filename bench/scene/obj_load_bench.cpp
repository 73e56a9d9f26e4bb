// Load time of the shared OBJ meshes (../shared/scenes, or RAYCLASS_SHARED_SCENES).
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "rayclass/scene/obj.h"

namespace {

std::filesystem::path SharedScene(const char* name) {
    const char* shared = std::getenv("RAYCLASS_SHARED_SCENES");
    const std::filesystem::path dir = shared ? std::filesystem::path(shared)
                                             : std::filesystem::path(__FILE__).parent_path() /
                                                   ".." / ".." / ".." / "shared" / "scenes";
    return dir / name;
}

void LoadObjFile(benchmark::State& state, const char* name) {
    const std::filesystem::path file = SharedScene(name);
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
