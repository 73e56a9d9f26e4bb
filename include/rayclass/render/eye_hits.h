// The renderer's hook for generation 0: a source of the eye rays' nearest hits in place of the
// ray query, e.g. the OpenGL raster pass (raster/raster_pass.h).
#pragma once

#include <string>
#include <vector>

#include "rayclass/render/device_scene.h"
#include "rayclass/render/stats.h"
#include "rayclass/scene/scene.h"
#include "rc_types.h"

namespace rayclass::render {

class EyeHitSource {
  public:
    virtual ~EyeHitSource() = default;
    virtual std::string Name() const = 0;
    // One RcHit per pixel of the camera's window, row-major, row 0 at the top, for the rays
    // rc_generate_eye_rays makes from `camera`.
    virtual std::vector<RcHit> FindHits(const scene::Scene& scene, const CameraBasis& camera,
                                        RenderStats& stats) = 0;
};

}  // namespace rayclass::render
