// Tiles (crops of one render, image.h's placement) put together into the whole image.
#pragma once

#include <string>
#include <vector>

#include "rayclass/image/image.h"

namespace rayclass::image {

// A tile and the name its messages give it (its file).
struct NamedTile {
    std::string name;
    Image image;
};

// The whole image `tiles` are parts of: every tile's pixels and layers in its place, the scene
// hash kept. Throws rayclass::Error naming the tiles concerned when they do not belong to one
// image (different display windows, layer sets or scene hashes), when two overlap, or, unless
// `allowPartial` (which leaves the rest black, with the layers of misses), when pixels are
// covered by no tile (naming the missing rectangles).
Image MergeTiles(const std::vector<NamedTile>& tiles, bool allowPartial);

}  // namespace rayclass::image
