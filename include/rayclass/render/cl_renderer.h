// The OpenCL Whitted renderer: eye rays from a kernel, then generation by generation a ray query
// (behind RayQuery, so accelerations swap in locally), a shading kernel that spawns shadow,
// reflection and refraction rays, and a shadow query. Contributions are accumulated per pixel on
// the host in ray order, so a render is reproducible bit for bit.
#pragma once

#include "rayclass/clrt/context.h"
#include "rayclass/image/image.h"
#include "rayclass/render/eye_hits.h"
#include "rayclass/render/options.h"
#include "rayclass/render/stats.h"
#include "rayclass/scene/scene.h"

namespace rayclass::render {

class ClRenderer {
  public:
    // `eyeHits` (null: the ray query) answers generation 0; the eye rays themselves come from
    // the kernel either way.
    ClRenderer(clrt::Context& ctx, const scene::Scene& scene, const RenderOptions& options,
               EyeHitSource* eyeHits = nullptr);
    image::Image Render(RenderStats& stats);

  private:
    clrt::Context& ctx_;
    const scene::Scene& scene_;
    RenderOptions options_;
    EyeHitSource* eyeHits_;
};

}  // namespace rayclass::render
