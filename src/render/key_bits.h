// The pieces of the host's ray sort keys (RayOrder, ShadowOrder): a coordinate as a grid cell,
// and two cells' bits interleaved.
#pragma once

#include <algorithm>
#include <cstdint>

namespace rayclass::render {

// A coordinate in [lo, lo + cells / scale) as a cell below `cells`; outside it the nearest
// cell, NaN in cell 0.
inline uint32_t Cell(float x, float lo, float scale, int cells) {
    const float c = std::clamp((x - lo) * scale, 0.0f, float(cells - 1));
    return c >= 0.0f ? uint32_t(c) : 0u;
}

// The bits of x (below 2^8) spread to every second position.
inline uint32_t Spread2(uint32_t x) {
    x = (x | x << 4) & 0x0F0Fu;
    x = (x | x << 2) & 0x3333u;
    return (x | x << 1) & 0x5555u;
}

}  // namespace rayclass::render
