#include "rayclass/bvh/quantised_node.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <stdexcept>

namespace rayclass::bvh {

namespace {

// A grid step of at least 2^-100, over an origin that is normal or zero, keeps every grid value
// normal or zero, so a device that flushes subnormals computes the same floats.
constexpr int kMinExponent = 27;  // biased: 2^(27 - 127)
constexpr int kMaxExponent = 254;

// Grid value q of an axis, with the kernels' float operations (the product is exact).
float GridValue(float origin, int exponent, uint32_t q) {
    return origin + float(q) * std::ldexp(1.0f, exponent - 127);
}

// Zero for a subnormal origin at least zero, the least normal negative float for one below.
float NormalAtMost(float x) {
    if (x == 0.0f || std::abs(x) >= FLT_MIN) return x;
    return x > 0.0f ? 0.0f : -FLT_MIN;
}

struct Axis {
    float origin;
    int exponent;

    float Value(uint32_t q) const { return GridValue(origin, exponent, q); }

    // The largest grid value at most x (x at least the origin).
    uint8_t Below(float x) const {
        const double step = std::ldexp(1.0, exponent - 127);
        auto q = uint32_t(std::clamp(std::floor((double(x) - origin) / step), 0.0, 255.0));
        while (q < 255 && Value(q + 1) <= x) ++q;
        while (Value(q) > x) --q;  // Value(0) is the origin
        return uint8_t(q);
    }

    // The smallest grid value at least x (x at most Value(255)).
    uint8_t Above(float x) const {
        const double step = std::ldexp(1.0, exponent - 127);
        auto q = uint32_t(std::clamp(std::ceil((double(x) - origin) / step), 0.0, 255.0));
        while (q > 0 && Value(q - 1) >= x) --q;
        while (Value(q) < x) ++q;
        return uint8_t(q);
    }
};

// The grid from lo on whose 255th value is the first at least hi, with the finest step that
// reaches it.
Axis MakeAxis(float lo, float hi) {
    Axis a{NormalAtMost(lo), kMinExponent};
    const double ext = (double(hi) - a.origin) / 255.0;
    if (ext > 0.0) {
        int e2 = 0;
        std::frexp(ext, &e2);  // ext < 2^e2
        a.exponent = std::max(kMinExponent, e2 - 1 + 127);
    }
    while (a.Value(255) < hi) {
        if (++a.exponent > kMaxExponent)
            throw std::runtime_error("bvh: a node box too large to quantise");
    }
    // A coarser estimate may have overshot: the finest step that still reaches hi.
    while (a.exponent > kMinExponent && GridValue(a.origin, a.exponent - 1, 255) >= hi)
        --a.exponent;
    return a;
}

}  // namespace

RcBvh8QNode Quantise(const RcBvh8Node& node) {
    RcBvh8QNode q{};
    q.nChildren = uint8_t(node.nChildren);
    const float* lo[3] = {node.loX, node.loY, node.loZ};
    const float* hi[3] = {node.hiX, node.hiY, node.hiZ};
    uint8_t* qlo[3] = {q.loX, q.loY, q.loZ};
    uint8_t* qhi[3] = {q.hiX, q.hiY, q.hiZ};
    for (int a = 0; a < 3; ++a) {
        float boxLo = 0.0f, boxHi = 0.0f;
        if (node.nChildren > 0) {
            boxLo = *std::min_element(lo[a], lo[a] + node.nChildren);
            boxHi = *std::max_element(hi[a], hi[a] + node.nChildren);
        }
        const Axis axis = MakeAxis(boxLo, boxHi);
        q.origin[a] = axis.origin;
        q.exponent[a] = uint8_t(axis.exponent);
        for (uint32_t c = 0; c < node.nChildren; ++c) {
            qlo[a][c] = axis.Below(lo[a][c]);
            qhi[a][c] = axis.Above(hi[a][c]);
        }
    }
    for (uint32_t c = 0; c < 8; ++c) q.child[c] = node.child[c];
    return q;
}

}  // namespace rayclass::bvh
