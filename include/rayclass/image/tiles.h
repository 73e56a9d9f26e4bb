// Parts of an image: pixel rectangles, as a crop names them and as an image is cut into tiles
// that separate processes (or cluster tasks) render and `rayclass merge` puts together again.
#pragma once

#include <cstdint>
#include <string>

namespace rayclass::image {

// Pixels x0 <= x < x1, y0 <= y < y1 of an image, row 0 at the top.
struct PixelRect {
    uint32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;

    uint32_t Width() const { return x1 - x0; }
    uint32_t Height() const { return y1 - y0; }
    uint64_t PixelCount() const { return uint64_t(Width()) * Height(); }
    bool Empty() const { return x1 <= x0 || y1 <= y0; }
    bool Inside(uint32_t width, uint32_t height) const { return x1 <= width && y1 <= height; }
    bool Overlaps(const PixelRect& o) const {
        return x0 < o.x1 && o.x0 < x1 && y0 < o.y1 && o.y0 < y1;
    }
    bool operator==(const PixelRect&) const = default;
    // "X0,Y0,X1,Y1", as --crop takes it.
    std::string ToString() const;
};

// Tile `index` of `count` tiles of a width x height image. The tiles cover the image without
// overlap and stay compact whatever the count: rows of tiles as close to square as the count
// allows, each row holding its share of the count (rows differ by at most one tile), numbered
// row by row from the top left. Throws rayclass::Error when index >= count or the image has
// too few pixels for `count` non-empty tiles.
PixelRect TileRect(uint32_t index, uint32_t count, uint32_t width, uint32_t height);

}  // namespace rayclass::image
