// The order in which shadow rays go to the BVH's beam walk (cl/bvh.cl, rc_occluded_bvh): rays
// that end in the same light and leave it in nearly the same direction follow each other, so
// that a packet of 16 of them, walked backwards from the light, is a narrow beam from one point
// whatever the spread of the surfaces it reaches.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "rayclass/core/bounds.h"
#include "rc_types.h"

namespace rayclass::render {

class ShadowOrder {
  public:
    // Ends are placed on a coarse grid over `box` (those outside it on its faces) to keep the
    // rays of different lights apart.
    explicit ShadowOrder(const Bounds3f& box);

    // The positions of `rays` in order: a hash of the grid cell of the ray's end, then the Morton
    // code of its reversed direction's cell on an octahedral map; empty slots (tmax 0) last.
    // Equal keys keep their order, so the result depends on the rays only.
    const std::vector<uint32_t>& Sort(std::span<const RcRay> rays);

    // The share of a sample of the packets of 16 consecutive rays that would not walk the tree
    // as one in the rays' own order.
    double IncoherentShare(std::span<const RcRay> rays) const;

  private:
    uint32_t Key(const RcRay& ray) const;

    float lo_[3], scale_[3];
    float maxSpread2_;  // rc_bvh_max_spread2's bound on a packet's origins
    std::vector<uint16_t> keys_;
    std::vector<uint32_t> start_, order_;  // start_: each key's next position
};

}  // namespace rayclass::render
