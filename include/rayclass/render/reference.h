// The reference renderer: the same Whitted model as the kernels (cl/shade.cl), traced recursively
// on the host in double precision with brute-force queries. It is slow on purpose and simple
// enough to trust: every other path is measured against it.
#pragma once

#include "rayclass/image/image.h"
#include "rayclass/render/options.h"
#include "rayclass/render/stats.h"
#include "rayclass/scene/scene.h"

namespace rayclass::render {

image::Image RenderReference(const scene::Scene& scene, const RenderOptions& options,
                             RenderStats& stats);

}  // namespace rayclass::render
