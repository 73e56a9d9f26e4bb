#include "ray_order.h"

#include <algorithm>
#include <cmath>

#include "key_bits.h"

namespace rayclass::render {

namespace {

// Grid cells per axis: 2^kCellBits. A packet walks as one when its origins lie within a 32nd of
// the scene's box (rc_bvh_max_spread2), so finer cells only spend key bits.
constexpr int kCellBits = 5;
// Direction cells per axis of an octant's octahedral map: 2^kDirBits, about 11 degrees wide,
// inside the 18 degrees a packet's directions may spread.
constexpr int kDirBits = 3;
constexpr int kKeyBits = 3 + 3 * kCellBits + 2 * kDirBits;

// The bits of v (below 2^10) spread to every third position.
uint32_t Spread(uint32_t x) {
    x = (x | x << 8) & 0x0000F00Fu;
    x = (x | x << 4) & 0x000C30C3u;
    x = (x | x << 2) & 0x00249249u;
    return x;
}

// The cell of d on its octant's face of the octahedral map (|x| and |y| over the L1 norm),
// the two coordinates' bits interleaved; a zero direction in cell 0.
uint32_t DirectionCell(const float d[3]) {
    const float ax = std::fabs(d[0]), ay = std::fabs(d[1]), az = std::fabs(d[2]);
    const float sum = ax + ay + az;
    constexpr int kCells = 1 << kDirBits;
    return Spread2(Cell(ax / sum, 0.0f, float(kCells), kCells)) << 1 |
           Spread2(Cell(ay / sum, 0.0f, float(kCells), kCells));
}

}  // namespace

RayOrder::RayOrder(const Bounds3f& box) {
    for (int a = 0; a < 3; ++a) {
        const float extent = box.Empty() ? 0.0f : box.hi[a] - box.lo[a];
        lo_[a] = box.Empty() ? 0.0f : box.lo[a];
        scale_[a] = extent > 0.0f ? float(1 << kCellBits) / extent : 0.0f;
    }
}

uint32_t RayOrder::Key(const RcRay& ray) const {
    const float o[3] = {ray.origin.x, ray.origin.y, ray.origin.z};
    const float d[3] = {ray.direction.x, ray.direction.y, ray.direction.z};
    uint32_t morton = 0, octant = 0;
    for (int a = 0; a < 3; ++a) {
        morton |= Spread(Cell(o[a], lo_[a], scale_[a], 1 << kCellBits)) << a;
        octant |= uint32_t(std::signbit(d[a])) << a;
    }
    return (octant << (3 * kCellBits) | morton) << (2 * kDirBits) | DirectionCell(d);
}

void RayOrder::Sort(std::span<const RcRay> rays, std::span<uint32_t> slots,
                    std::span<uint32_t> pixels) {
    const size_t n = slots.size();
    std::vector<uint32_t>& keys = radix_.bits;
    keys.resize(n);
    order_.resize(n);
    // One thread: the renderer orders a batch on a worker beside its shadow query, whose
    // classification holds the other core.
    for (size_t i = 0; i < n; ++i) {
        keys[i] = Key(rays[slots[i]]);
        order_[i] = uint32_t(i);
    }
    // Stable: equal keys keep their order.
    RadixSortByBits<12>(keys, order_, kKeyBits, radix_);
    scratch_.assign(slots.begin(), slots.end());
    for (size_t i = 0; i < n; ++i) slots[i] = scratch_[order_[i]];
    scratch_.assign(pixels.begin(), pixels.end());
    for (size_t i = 0; i < n; ++i) pixels[i] = scratch_[order_[i]];
}

}  // namespace rayclass::render
