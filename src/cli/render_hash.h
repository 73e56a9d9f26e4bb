// What a render draws, as a hash: two renders with the same hash give the same pixels, so tiles
// with different hashes belong to different images and `rayclass merge` refuses them together.
#pragma once

#include <string>

#include "rayclass/render/options.h"
#include "rayclass/scene/scene.h"

namespace rayclass::cli {

// 16 hex digits: FNV-1a (64 bits) over the loaded scene (camera and image size included) and
// the options that change pixels (depth, weight, triangle test, ray encoding, reference), not
// over those that only change how the same pixels are found (query, kernels, batches, crop).
std::string RenderHash(const scene::Scene& scene, const render::RenderOptions& options,
                       bool reference);

}  // namespace rayclass::cli
