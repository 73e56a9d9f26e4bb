#include "rayclass/render/query_factory.h"

#include <algorithm>
#include <chrono>
#include <utility>

#include "rayclass/classify/params.h"
#include "rayclass/render/auto_query.h"
#include "rayclass/render/brute_query.h"
#include "rayclass/render/bvh_query.h"
#include "rayclass/render/classified_query.h"
#include "rayclass/render/cones_query.h"
#include "rayclass/render/grid_query.h"
#include "rayclass/render/kdtree_query.h"

namespace rayclass::render {

namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

// Some material spawns mirror or refracted rays.
bool SpawnsSecondaryRays(const scene::Scene& scene) {
    return std::ranges::any_of(scene.materials, [](const scene::Material& m) {
        return m.kr != glm::vec3(0.0f) || m.kt != glm::vec3(0.0f);
    });
}

}  // namespace

std::shared_ptr<BvhBuild> StartBvhBuild(const scene::Scene& scene, const RenderOptions& options) {
    const bool auto_secondary =
        options.accel == Accel::kAuto && options.maxDepth > 0 && SpawnsSecondaryRays(scene);
    if (options.accel != Accel::kBvh && !auto_secondary) return nullptr;
    return std::make_shared<BvhBuild>(scene);
}

std::unique_ptr<RayQuery> MakeQuery(clrt::Context& ctx, const cl::Program& program,
                                    const SceneBuffers& buffers, const scene::Scene& scene,
                                    const RenderOptions& options, RenderStats& stats,
                                    std::shared_ptr<BvhBuild> bvhBuild) {
    if (options.accel == Accel::kBrute) return MakeBruteForceQuery(ctx, program, buffers);
    auto makeBvh = [&ctx, &program, &buffers, &scene, &stats, bvhBuild] {
        const auto t0 = Clock::now();
        BvhBuild::Result built = bvhBuild ? bvhBuild->Take() : BvhBuild(scene).Take();
        auto query = MakeBvhQuery(ctx, program, buffers, std::move(built.tree));
        stats.timeS["bvh_build"] = SecondsSince(t0);
        stats.timeS["bvh_build_thread"] = built.seconds;
        return query;
    };
    if (options.accel == Accel::kBvh) return makeBvh();
    if (options.accel == Accel::kKdTree) {
        const auto t0 = Clock::now();
        auto query = MakeKdTreeQuery(ctx, program, buffers, scene);
        stats.timeS["kdtree_build"] = SecondsSince(t0);
        return query;
    }
    if (options.accel == Accel::kCones) return MakeConesQuery(ctx, program, buffers, scene);
    if (options.accel == Accel::kGrid) {
        const auto t0 = Clock::now();
        auto query = MakeGridQuery(ctx, program, buffers, scene);
        stats.timeS["grid_build"] = SecondsSince(t0);
        return query;
    }
    const auto t0 = Clock::now();
    classify::Params params = classify::Params::ForScene(scene);
    for (const classify::ParamSetting& setting : options.classifyParams) setting.ApplyTo(params);
    auto query =
        MakeClassifiedQuery(ctx, program, buffers, scene, params, ClassifiedStyle(options));
    stats.timeS["classify_setup"] = SecondsSince(t0);
    if (options.accel == Accel::kAuto) return MakeAutoQuery(ctx, std::move(query), makeBvh);
    return query;
}

}  // namespace rayclass::render
