// Where a spawned ray starts: the hit point moved off the surface along the geometric normal by a
// distance that scales with the point's magnitude (a fixed number of ulps), after Waechter &
// Binder, "A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems ch. 6.
// Near the origin, where ulps vanish, a small absolute offset takes over. The kernels use the
// same constants (rc_offset_ray_origin in cl/intersect.cl) for float.
#pragma once

#include <bit>
#include <cmath>
#include <cstdint>

#include <glm/glm.hpp>

namespace rayclass::geometry {

template <typename T>
struct OffsetConstants;

template <>
struct OffsetConstants<float> {
    using Int = int32_t;
    static constexpr float kOrigin = 1.0f / 32.0f;
    static constexpr float kFloatScale = 1.0f / 65536.0f;
    static constexpr float kIntScale = 256.0f;
};

// Same number of ulps in double; the absolute term shrinks by the 2^29 finer ulp.
template <>
struct OffsetConstants<double> {
    using Int = int64_t;
    static constexpr double kOrigin = 1.0 / 32.0;
    static constexpr double kFloatScale = 1.0 / 65536.0 / 536870912.0;
    static constexpr double kIntScale = 256.0;
};

// `n` is the unit geometric normal on the side the new ray leaves towards.
template <typename T>
glm::vec<3, T> OffsetRayOrigin(const glm::vec<3, T>& p, const glm::vec<3, T>& n) {
    using C = OffsetConstants<T>;
    using Int = typename C::Int;
    glm::vec<3, T> out;
    for (int i = 0; i < 3; ++i) {
        if (std::abs(p[i]) < C::kOrigin) {
            out[i] = p[i] + C::kFloatScale * n[i];
            continue;
        }
        // Only here: near zero (-0 is INT_MIN's bits) the step could overflow the integer.
        const Int ulps = Int(C::kIntScale * n[i]);
        const Int bits = std::bit_cast<Int>(p[i]);
        out[i] = std::bit_cast<T>(bits + (p[i] < T(0) ? -ulps : ulps));
    }
    return out;
}

}  // namespace rayclass::geometry
