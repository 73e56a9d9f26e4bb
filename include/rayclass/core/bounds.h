// Axis-aligned bounding boxes. An empty box has lo > hi on every axis, so growing it by a point
// gives that point's box.
#pragma once

#include <glm/glm.hpp>
#include <limits>

namespace rayclass {

template <typename T>
struct Bounds3 {
    using Vec = glm::vec<3, T>;
    Vec lo{std::numeric_limits<T>::infinity()};
    Vec hi{-std::numeric_limits<T>::infinity()};

    bool Empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
    void Grow(const Vec& p) {
        lo = glm::min(lo, p);
        hi = glm::max(hi, p);
    }
    void Grow(const Bounds3& b) {
        lo = glm::min(lo, b.lo);
        hi = glm::max(hi, b.hi);
    }
    Vec Size() const { return Empty() ? Vec(0) : hi - lo; }
    Vec Center() const { return (lo + hi) * T(0.5); }
    T Diagonal() const { return glm::length(Size()); }
    bool Contains(const Vec& p) const {
        return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z &&
               p.z <= hi.z;
    }
};

using Bounds3f = Bounds3<float>;
using Bounds3d = Bounds3<double>;

}  // namespace rayclass
