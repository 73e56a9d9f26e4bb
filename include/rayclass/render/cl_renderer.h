// The OpenCL Whitted renderer. Each generation of rays goes through the same stages, batch by
// batch: generate (eye rays, by a kernel) -> prepare (the query's host work, e.g. classification,
// on a worker thread one batch ahead) -> intersect (the ray query, behind RayQuery, so
// accelerations swap in locally) -> shade (a kernel that spawns shadow, reflection and refraction
// rays) -> occlude (the shadow query) -> accumulate -> compact (the spawned rays into the next
// generation's pages). Contributions are accumulated per pixel on the host in ray order, so a
// render is reproducible bit for bit.
#pragma once

#include <functional>
#include <memory>

#include "rayclass/clrt/context.h"
#include "rayclass/image/image.h"
#include "rayclass/render/eye_hits.h"
#include "rayclass/render/frame_program.h"
#include "rayclass/render/options.h"
#include "rayclass/render/ray_query.h"
#include "rayclass/render/stats.h"
#include "rayclass/scene/scene.h"

namespace rayclass::render {

// Takes the query a render builds and returns the one it uses: a decorator that sees every
// generation's rays and answers (the tests' check of every hit against brute force).
using QueryWrapper = std::function<std::unique_ptr<RayQuery>(std::unique_ptr<RayQuery>)>;
// Gives the program a render uses, waiting for it where it is still being built.
using ProgramSource = std::function<FrameProgram()>;

class ClRenderer {
  public:
    // `eyeHits` (null: the ray query) answers generation 0; the eye rays themselves come from
    // the kernel either way. `wrapQuery` (empty: none) wraps the query of each Render.
    ClRenderer(clrt::Context& ctx, const scene::Scene& scene, const RenderOptions& options,
               EyeHitSource* eyeHits = nullptr, QueryWrapper wrapQuery = {});
    // Without UseProgram, Render builds (or loads from the program cache) the shared program of
    // these options' build options (BuildSharedFrameProgram), which renders of every --accel
    // share. UseProgram renders with `program` instead: one that ServesFrame these options, built
    // ahead (e.g. while the scene loads) or shared by several renders; BuildFrameProgram's loads
    // quicker, for a command's one render. Throws std::invalid_argument for any other program.
    void UseProgram(FrameProgram program);
    // As UseProgram, with a program still being built (e.g. on the thread that started the
    // device): Render calls `program` once the frame's set-up that needs no program is done, so
    // that set-up overlaps the build, and throws std::invalid_argument where it does not serve.
    void AwaitProgram(ProgramSource program);
    image::Image Render(RenderStats& stats);

  private:
    clrt::Context& ctx_;
    const scene::Scene& scene_;
    RenderOptions options_;
    EyeHitSource* eyeHits_;
    QueryWrapper wrapQuery_;
    ProgramSource program_;  // empty: the shared program
};

}  // namespace rayclass::render
