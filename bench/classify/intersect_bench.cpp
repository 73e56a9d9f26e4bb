// Per-test costs of the cost function (include/rayclass/classify/params.h): one float
// intersection test of geometry/intersect.h per primitive type, one candidate box test of the
// list filter and one ray moved by a partition. Each iteration tests one ray against 4096 random
// primitives (or moves the benchmark's rays once), so the figure per test is the time per
// iteration / 4096 (items_per_second inverts it).
#include <benchmark/benchmark.h>

#include <random>

#include "filter.h"
#include "partition.h"
#include "rayclass/classify/query.h"

namespace {

using namespace rayclass;

constexpr int kPrims = 4096;

scene::Scene MakeScene(int kind) {
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> pos(-1.0f, 1.0f), off(-0.1f, 0.1f), rad(0.02f, 0.1f);
    scene::Scene s;
    for (int i = 0; i < kPrims; ++i) {
        const glm::vec3 c(pos(rng), pos(rng), pos(rng));
        if (kind == 0) {
            scene::Triangle t;
            t.p = {c + glm::vec3(off(rng), off(rng), off(rng)), c + glm::vec3(off(rng), off(rng), off(rng)),
                   c + glm::vec3(off(rng), off(rng), off(rng))};
            s.triangles.push_back(t);
        } else if (kind == 1) {
            s.spheres.push_back({c, rad(rng)});
        } else {
            scene::Quadric q;
            const float r = rad(rng);
            q.c = {1, 1, 1, 0, 0, 0, -2 * c.x, -2 * c.y, -2 * c.z,
                   c.x * c.x + c.y * c.y + c.z * c.z - r * r};
            q.boxMin = c - glm::vec3(r);
            q.boxMax = c + glm::vec3(r);
            s.quadrics.push_back(q);
        }
    }
    return s;
}

void BM_Intersect(benchmark::State& state) {
    const scene::Scene s = MakeScene(int(state.range(0)));
    std::mt19937 rng(2);
    std::normal_distribution<float> n;
    std::vector<geometry::Ray<float>> rays;
    for (int i = 0; i < 64; ++i) {
        rays.push_back({glm::vec3(-2.0f, 0.0f, 0.0f),
                        glm::normalize(glm::vec3(2.0f, 0.3f * n(rng), 0.3f * n(rng)))});
    }
    size_t r = 0;
    for (auto _ : state) {
        geometry::Hit<float> best;
        const auto& ray = rays[r++ & 63];
        for (uint32_t id = 0; id < kPrims; ++id) geometry::IntersectPrimitive(s, id, ray, best);
        benchmark::DoNotOptimize(best);
    }
    state.SetItemsProcessed(int64_t(state.iterations()) * kPrims);
}
BENCHMARK(BM_Intersect)->Arg(0)->Arg(1)->Arg(2)->ArgNames({"triangle0_sphere1_quadric2"});

void BM_FilterBoxes(benchmark::State& state) {
    const scene::Scene s = MakeScene(0);
    classify::Hierarchy h(s, classify::Params::ForScene(s));
    (void)h;
    std::mt19937 rng(3);
    std::uniform_real_distribution<float> pos(-1.0f, 1.0f);
    classify::FaceList in, out;
    in.Resize(kPrims);
    out.Resize(kPrims);
    // Boxes in [-1, 1.1] on every axis, in 16-bit steps as the face lists hold them.
    classify::ListFrame frame;
    frame.base[0] = frame.base[1] = frame.base[2] = -1.0f;
    frame.step = 2.1f / 65534.0f * 1.0001f;
    for (int i = 0; i < kPrims; ++i) {
        const float x = pos(rng), y = pos(rng), z = pos(rng);
        in.x0[i] = classify::StepsBelow(frame, 0, x);
        in.x1[i] = classify::StepsAbove(frame, 0, x + 0.1f);
        in.y0[i] = classify::StepsBelow(frame, 1, y);
        in.y1[i] = classify::StepsAbove(frame, 1, y + 0.1f);
        in.z0[i] = classify::StepsBelow(frame, 2, z);
        in.z1[i] = classify::StepsAbove(frame, 2, z + 0.1f);
        in.prim[i] = uint32_t(i);
    }
    // Arg 0: a beam about as selective as mid-level nodes of sibenik's mirror rays (a few %
    // kept). Arg 1: one that keeps about 40 %, as the filters of 1k-32k boxes that make most of
    // the box tests in sibenik's deep mirror generations do.
    classify::Box5 b;
    if (state.range(0) == 0) {
        b.lo = {-1.0f, -0.1f, -0.1f, -0.2f, 0.1f};
        b.hi = {-0.9f, 0.0f, 0.0f, -0.1f, 0.2f};
    } else {
        b.lo = {-1.0f, -0.3f, -0.3f, -0.3f, -0.2f};
        b.hi = {-0.9f, 0.3f, 0.3f, 0.3f, 0.2f};
    }
    const auto test = classify::MakeBeamTest(frame, b, 10.0f);
    const classify::ListView view = classify::View(in, kPrims, &frame);
    size_t kept = 0;
    for (auto _ : state) {
        kept = classify::FilterList(test, view, classify::Out(out, 0));
        benchmark::DoNotOptimize(out.prim.data());
    }
    state.counters["kept"] = double(kept);
    state.SetItemsProcessed(int64_t(state.iterations()) * kPrims);
}
// A node's two-way partition of its rays between the ping-pong buffers, half of the rays to each
// side; `active` the coordinates moved with the ids: 63 all six (mirror rays), 56 direction and
// end (shadow rays from their light), 24 direction only (eye rays).
// n rays in the ping-pong buffers' structure of arrays: random coordinates, ids in order.
struct RayBuffers {
    ScratchVector<float> from[classify::kCoords], to[classify::kCoords];
    ScratchVector<uint32_t> fromId, toId;

    RayBuffers(uint32_t n, uint32_t seed) : fromId(n), toId(n) {
        std::mt19937 rng(seed);
        std::uniform_real_distribution<float> pos(-1.0f, 1.0f);
        for (int k = 0; k < classify::kCoords; ++k) {
            from[k].resize(n);
            to[k].resize(n);
            for (uint32_t i = 0; i < n; ++i) from[k][i] = pos(rng);
        }
        for (uint32_t i = 0; i < n; ++i) fromId[i] = i;
    }
    classify::PartitionIo Io() { return classify::Between(from, to, fromId, toId); }
};

void BM_PartitionRays(benchmark::State& state) {
    const uint32_t n = uint32_t(state.range(0));
    const int active = int(state.range(1));
    RayBuffers b(n, 5);
    classify::PartitionIo io = b.Io();
    io.key = b.from[3].data();
    classify::Bounds6 left, right;
    uint32_t mid = 0;
    for (auto _ : state) {
        mid = classify::PartitionRays(active, io, 0.0f, 0, n, left, right);
        benchmark::DoNotOptimize(b.toId.data());
    }
    state.counters["left"] = double(mid);
    state.SetItemsProcessed(int64_t(state.iterations()) * n);
}
BENCHMARK(BM_PartitionRays)
    ->ArgsProduct({{4096, 65536}, {63, 56, 24}})
    ->ArgNames({"rays", "active"});

// A plan's four levels of splits at once (16 cells) over the rays of a 1024-wide image in
// scanline order (coordinates 3 and 4 its columns and rows, the others random), on one thread;
// `active` as for BM_PartitionRays.
void BM_BucketRays(benchmark::State& state) {
    const uint32_t n = uint32_t(state.range(0));
    const int activeMask = int(state.range(1));
    RayBuffers b(n, 6);
    const uint32_t rows = (n + 1023) / 1024;
    for (uint32_t i = 0; i < n; ++i) {
        b.from[3][i] = float(i % 1024) / 512.0f - 1.0f;
        b.from[4][i] = float(i / 1024) / float(rows) * 2.0f - 1.0f;
    }
    bool active[classify::kCoords];
    for (int k = 0; k < classify::kCoords; ++k) active[k] = (activeMask >> k) & 1;
    const int dim[4] = {3, 4, 3, 4};
    // Heap order: each cell a quarter of the image's width and height.
    const float value[15] = {0.0f,  0.0f, 0.0f, -0.5f, -0.5f, 0.5f, 0.5f, -0.5f,
                             -0.5f, 0.5f, 0.5f, -0.5f, -0.5f, 0.5f, 0.5f};
    const classify::CellRule rule{4, dim, value};
    const classify::PartitionIo io = b.Io();
    uint32_t cellBegin[17];
    classify::Bounds6 cell[16];
    for (auto _ : state) {
        classify::BucketRays(io, active, rule, 0, n, cellBegin, cell, 1);
        benchmark::DoNotOptimize(b.toId.data());
    }
    state.SetItemsProcessed(int64_t(state.iterations()) * n);
}
BENCHMARK(BM_BucketRays)->ArgsProduct({{65536, 786432}, {63, 24}})->ArgNames({"rays", "active"});

BENCHMARK(BM_FilterBoxes)->Arg(0)->Arg(1)->ArgNames({"wide"});

}  // namespace

BENCHMARK_MAIN();
