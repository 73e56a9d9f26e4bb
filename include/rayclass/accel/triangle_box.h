// Where a primitive meets an axis-aligned box, in double precision: the box of the part of a
// triangle inside a box (Sutherland-Hodgman clipping), and whether a triangle overlaps a box at
// all (the separating-axis test of Akenine-Moeller 2001). The kd-tree clips its primitives to
// its nodes with the first; the grid voxelizes triangles with the second.
#pragma once

#include <array>
#include <cstdint>
#include <glm/glm.hpp>

#include "rayclass/core/bounds.h"
#include "rayclass/scene/scene.h"

namespace rayclass::accel {

using Triangle3d = std::array<glm::dvec3, 3>;

// The box of triangle ∩ box (closed); empty when they do not meet.
Bounds3d ClipTriangle(const Triangle3d& tri, const Bounds3d& box);

// Whether the triangle and the box (closed) share a point. Degenerate triangles (segments,
// points) are tested by their edge and box axes alone, which keeps the answer conservative.
bool TriangleOverlapsBox(const Triangle3d& tri, const Bounds3d& box);

// The box of primitive `id` (global id) within `box`: a triangle clipped to it, a sphere or a
// quadric by its own box intersected with it. Empty when they do not meet.
Bounds3d PrimitiveExtentIn(const scene::Scene& scene, uint32_t id, const Bounds3d& box);

// The triangle `id` of the scene in double.
Triangle3d TriangleOf(const scene::Scene& scene, uint32_t id);

// `b` grown by `pad` on every side.
inline Bounds3d Padded(const Bounds3d& b, double pad) {
    return b.Empty() ? b : Bounds3d{b.lo - glm::dvec3(pad), b.hi + glm::dvec3(pad)};
}

// a ∩ b (empty when they do not meet).
inline Bounds3d Intersection(const Bounds3d& a, const Bounds3d& b) {
    return {glm::max(a.lo, b.lo), glm::min(a.hi, b.hi)};
}

}  // namespace rayclass::accel
