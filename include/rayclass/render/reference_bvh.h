// The reference renderer's acceleration: a bounding volume hierarchy built and traversed in
// double precision on the host, apart from the float BVH builder (src/bvh) and the kernels, so
// that the reference stays an independent oracle for them.
//
// Its answers equal geometry::IntersectBruteForce and geometry::Occluded exactly, in double (the
// reference renderer) or in float (the tests' oracle for the kernels' hits): the same primitive
// tests, the lower id winning among equal distances. A primitive's computed distance does not
// depend on the ray's far bound, so visiting primitives in another order and skipping boxes that
// start beyond the best distance changes nothing. Boxes are padded so that a primitive's hit
// computed in float never lies outside its box through rounding.
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "rayclass/geometry/intersect.h"
#include "rayclass/scene/scene.h"

namespace rayclass::render {

class ReferenceBvh {
  public:
    // Builds over every primitive of `scene` (binned surface area heuristic). `scene` must
    // outlive the hierarchy and stay unchanged.
    ReferenceBvh(const scene::Scene& scene, geometry::TriangleTest test);

    // The nearest hit in (ray.tMin, ray.tMax), as geometry::IntersectBruteForce<T> (T is float
    // or double). `tests` counts the primitive tests made.
    template <typename T>
    geometry::Hit<T> Nearest(const geometry::Ray<T>& ray, uint64_t& tests) const;
    // Whether any primitive is hit in (ray.tMin, ray.tMax), as geometry::Occluded<T>.
    template <typename T>
    bool Occluded(const geometry::Ray<T>& ray, uint64_t& tests) const;

    size_t NodeCount() const { return nodes_.size(); }
    // The most primitives in one leaf.
    uint32_t LargestLeaf() const;

    struct Box {
        glm::dvec3 lo{std::numeric_limits<double>::infinity()};
        glm::dvec3 hi{-std::numeric_limits<double>::infinity()};
    };

  private:
    // An inner node (count 0) has its first child at index + 1 and its second at `first`; a
    // leaf holds ids_[first, first + count).
    struct Node {
        Box box;
        uint32_t first = 0;
        uint32_t count = 0;
    };
    struct Build;

    template <typename T, typename Visit>
    void Traverse(const geometry::Ray<T>& ray, const T& bound, Visit&& visit) const;

    const scene::Scene& scene_;
    geometry::TriangleTest test_;
    std::vector<Node> nodes_;
    std::vector<uint32_t> ids_;
};

}  // namespace rayclass::render
