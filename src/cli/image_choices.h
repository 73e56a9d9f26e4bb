// The names of the image writer's choices, shared by the commands that write images.
#pragma once

#include "rayclass/image/image.h"
#include "rayclass/render/options.h"

namespace rayclass::cli {

inline constexpr render::Named<image::ExrCompression> kExrCompressions[] = {
    {"zip", image::ExrCompression::kZip},
    {"piz", image::ExrCompression::kPiz},
    {"none", image::ExrCompression::kNone}};

}  // namespace rayclass::cli
