#include "shadow_order.h"

#include <algorithm>
#include <cmath>

#include "key_bits.h"
#include "rayclass/core/two_halves.h"

namespace rayclass::render {

namespace {

// End cells per axis: 2^kEndBits, hashed to kLightBits; direction cells per octahedral axis:
// 2^kDirBits. One counting pass sorts by the key: its histogram stays in the L2 cache.
constexpr int kEndBits = 3, kLightBits = 3, kDirBits = 6;
constexpr int kKeyBits = kLightBits + 2 * kDirBits;
constexpr uint32_t kEmptyKey = 1u << kKeyBits;  // after every ray's key
static_assert(kEmptyKey <= 0xFFFFu);

// Packets sampled to judge the rays' own order.
constexpr size_t kSamplePackets = 1024;

// Whether rays [first, first + 16) of `rays` (the active ones, tmax > 0) would walk the tree as
// one packet in their own order: rc_bvh_load_packet's rule (directions within about 18 degrees
// of the first active one, in its octant; origins within `maxSpread2`).
bool Coherent(std::span<const RcRay> rays, size_t first, float maxSpread2) {
    const RcRay* lead = nullptr;
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = first; i < std::min(first + 16, rays.size()); ++i) {
        const RcRay& r = rays[i];
        if (r.direction.w == 0.0f) continue;
        if (!lead) lead = &r;
        const float d[3] = {r.direction.x, r.direction.y, r.direction.z};
        const float l[3] = {lead->direction.x, lead->direction.y, lead->direction.z};
        const float dd = d[0] * l[0] + d[1] * l[1] + d[2] * l[2];
        const float len2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        const float lead2 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
        for (int a = 0; a < 3; ++a)
            if (std::signbit(d[a]) != std::signbit(l[a])) return false;
        if (!(dd > 0.0f && dd * dd > 0.9025f * len2 * lead2)) return false;
        const float o[3] = {r.origin.x, r.origin.y, r.origin.z};
        for (int a = 0; a < 3; ++a) {
            lo[a] = std::min(lo[a], o[a]);
            hi[a] = std::max(hi[a], o[a]);
        }
    }
    if (!lead) return true;
    float spread2 = 0.0f;
    for (int a = 0; a < 3; ++a) spread2 += (hi[a] - lo[a]) * (hi[a] - lo[a]);
    return spread2 <= maxSpread2;
}

// Rays below this many have their keys computed on one thread.
constexpr size_t kParallelKeys = 65536;

}  // namespace

ShadowOrder::ShadowOrder(const Bounds3f& box) {
    const glm::vec3 e = box.Size() * (1.0f / 32.0f);
    maxSpread2_ = glm::dot(e, e);
    for (int a = 0; a < 3; ++a) {
        const float extent = box.Empty() ? 0.0f : box.hi[a] - box.lo[a];
        lo_[a] = box.Empty() ? 0.0f : box.lo[a];
        scale_[a] = extent > 0.0f ? float(1 << kEndBits) / extent : 0.0f;
    }
}

uint32_t ShadowOrder::Key(const RcRay& ray) const {
    const float tmax = ray.direction.w;
    if (tmax == 0.0f) return kEmptyKey;
    const float o[3] = {ray.origin.x, ray.origin.y, ray.origin.z};
    const float d[3] = {ray.direction.x, ray.direction.y, ray.direction.z};
    uint32_t end[3];
    for (int a = 0; a < 3; ++a) end[a] = Cell(o[a] + tmax * d[a], lo_[a], scale_[a], 1 << kEndBits);
    // The end's cell hashed: rays toward different lights (slots of one ray lie side by side)
    // rarely share a key.
    const uint32_t light =
        ((end[0] * 73856093u) ^ (end[1] * 19349663u) ^ (end[2] * 83492791u)) >> (32 - kLightBits);
    // The reversed direction -d on the octahedron |x| + |y| + |z| = 1, its lower half folded
    // out over the corners of the square.
    const float sum = std::fabs(d[0]) + std::fabs(d[1]) + std::fabs(d[2]);
    const float inv = sum > 0.0f ? -1.0f / sum : 0.0f;
    float u = d[0] * inv, v = d[1] * inv;
    if (d[2] * inv < 0.0f) {
        const float fu = std::copysign(1.0f - std::fabs(v), u);
        v = std::copysign(1.0f - std::fabs(u), v);
        u = fu;
    }
    constexpr float kHalf = float(1 << (kDirBits - 1));
    const uint32_t dir = Spread2(Cell(u, -1.0f, kHalf, 1 << kDirBits)) << 1 |
                         Spread2(Cell(v, -1.0f, kHalf, 1 << kDirBits));
    return light << (2 * kDirBits) | dir;
}

double ShadowOrder::IncoherentShare(std::span<const RcRay> rays) const {
    const size_t packets = (rays.size() + 15) / 16;
    if (packets == 0) return 0.0;
    const size_t samples = std::min(packets, kSamplePackets);
    size_t incoherent = 0;
    // Packets picked at a fixed pseudo-random offset within each stretch: evenly spaced ones
    // fall into the image's rows in step (Sibenik's eye hits: 0 of 256 where 9 % of all are).
    uint32_t state = 2463534242u;
    for (size_t s = 0; s < samples; ++s) {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        const size_t begin = s * packets / samples, end = (s + 1) * packets / samples;
        incoherent += !Coherent(rays, (begin + state % (end - begin)) * 16, maxSpread2_);
    }
    return double(incoherent) / double(samples);
}

const std::vector<uint32_t>& ShadowOrder::Sort(std::span<const RcRay> rays) {
    const size_t n = rays.size();
    keys_.resize(n);
    order_.resize(n);
    auto keysOf = [&](size_t begin, size_t end) {
        for (size_t i = begin; i < end; ++i) keys_[i] = uint16_t(Key(rays[i]));
    };
    InTwoHalves(n, kParallelKeys, keysOf);
    // A stable counting sort: equal keys keep their order.
    start_.assign(kEmptyKey + 2, 0);
    for (size_t i = 0; i < n; ++i) ++start_[keys_[i] + 1u];
    for (size_t k = 1; k < start_.size(); ++k) start_[k] += start_[k - 1];
    for (size_t i = 0; i < n; ++i) order_[start_[keys_[i]]++] = uint32_t(i);
    return order_;
}

}  // namespace rayclass::render
