// The order in which a generation's rays go to the query: rays that start close together and head
// into close directions follow each other, so that neighbouring rays walk the same nodes (a BVH's
// walks then find them in the caches, and its 16-ray packets find coherent rays) and shade the
// same triangles. Reflections off a large mirror leave it in pixel order, which the bounces
// scramble: after a few of them, neighbouring rays start on different walls.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rayclass/core/bounds.h"
#include "rayclass/core/radix_sort.h"
#include "rc_types.h"

namespace rayclass::render {

class RayOrder {
  public:
    // Origins are placed on a grid over `box` (those outside it on its faces).
    explicit RayOrder(const Bounds3f& box);

    // Reorders slots[first, end) and pixels[first, end) alike by the key of rays[slot]: the
    // direction's octant, then the Morton code of the origin's grid cell, then the direction's
    // cell within its octant (rays off curved or differently turned surfaces part there);
    // equal keys keep their order, so the result depends on the rays only.
    void Sort(std::span<const RcRay> rays, std::span<uint32_t> slots, std::span<uint32_t> pixels);

  private:
    uint32_t Key(const RcRay& ray) const;

    float lo_[3], scale_[3];
    RadixScratch radix_;  // radix_.bits holds the keys
    std::vector<uint32_t> order_, scratch_;
};

}  // namespace rayclass::render
