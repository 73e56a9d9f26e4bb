#include "rayclass/image/tiles.h"

#include <algorithm>
#include <cmath>

#include "rayclass/core/error.h"

namespace rayclass::image {

std::string PixelRect::ToString() const {
    return std::to_string(x0) + "," + std::to_string(y0) + "," + std::to_string(x1) + "," +
           std::to_string(y1);
}

namespace {

// The longest side of `count` tiles in `rows` rows over the shortest, worst tile of all.
double WorstAspect(uint32_t count, uint32_t rows, uint32_t width, uint32_t height) {
    double worst = 1.0;
    for (uint32_t inRow : {count / rows, (count + rows - 1) / rows}) {
        const double aspect = (double(width) / inRow) / (double(height) / rows);
        worst = std::max(worst, std::max(aspect, 1.0 / aspect));
    }
    return worst;
}

// Rows of tiles for `count` tiles: square tiles of a width x height image would come in
// sqrt(count * height / width) rows; of the whole numbers either side, the one whose worst tile
// is nearer square.
uint32_t TileRows(uint32_t count, uint32_t width, uint32_t height) {
    const double ideal = std::sqrt(double(count) * height / width);
    const double most = double(std::min(count, height));
    const uint32_t below = uint32_t(std::clamp(std::floor(ideal), 1.0, most));
    const uint32_t above = uint32_t(std::clamp(std::ceil(ideal), 1.0, most));
    return WorstAspect(count, above, width, height) < WorstAspect(count, below, width, height)
               ? above
               : below;
}

}  // namespace

PixelRect TileRect(uint32_t index, uint32_t count, uint32_t width, uint32_t height) {
    if (count == 0 || index >= count) {
        throw Error("tile " + std::to_string(index) + "/" + std::to_string(count) +
                    " does not exist (tiles are numbered 0 to N-1)");
    }
    const uint32_t rows = TileRows(count, width, height);
    // Row r holds tiles [count * r / rows, count * (r + 1) / rows).
    const auto firstOfRow = [&](uint32_t r) { return uint32_t(uint64_t(count) * r / rows); };
    uint32_t row = 0;
    while (firstOfRow(row + 1) <= index) ++row;
    const uint32_t inRow = firstOfRow(row + 1) - firstOfRow(row), column = index - firstOfRow(row);
    if ((count + rows - 1) / rows > width) {
        throw Error(std::to_string(count) + " tiles do not fit a " + std::to_string(width) + "x" +
                    std::to_string(height) + " image");
    }
    PixelRect r;
    r.x0 = uint32_t(uint64_t(width) * column / inRow);
    r.x1 = uint32_t(uint64_t(width) * (column + 1) / inRow);
    r.y0 = uint32_t(uint64_t(height) * row / rows);
    r.y1 = uint32_t(uint64_t(height) * (row + 1) / rows);
    return r;
}

}  // namespace rayclass::image
