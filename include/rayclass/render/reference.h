// The reference renderer: the same Whitted model as the kernels (cl/shade.cl), traced recursively
// on the host in double precision, simple enough to trust: every other path is measured against
// it. Its queries go through a double-precision BVH of its own (reference_bvh.h), whose hits equal
// brute force's exactly, or, with ReferenceQuery::kBruteForce, test every primitive.
#pragma once

#include "rayclass/image/image.h"
#include "rayclass/render/options.h"
#include "rayclass/render/stats.h"
#include "rayclass/scene/scene.h"

namespace rayclass::render {

enum class ReferenceQuery { kBvh, kBruteForce };

image::Image RenderReference(const scene::Scene& scene, const RenderOptions& options,
                             RenderStats& stats, ReferenceQuery query = ReferenceQuery::kBvh);

}  // namespace rayclass::render
