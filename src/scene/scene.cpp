#include "rayclass/scene/scene.h"

#include <algorithm>
#include <cmath>

namespace rayclass::scene {

Bounds3f Scene::PrimitiveBounds(uint32_t id) const {
    Bounds3f b;
    if (id < triangles.size()) {
        for (const auto& p : triangles[id].p) b.Grow(p);
    } else if (id < QuadricBase()) {
        const Sphere& s = spheres[id - SphereBase()];
        b.lo = s.center - glm::vec3(s.radius);
        b.hi = s.center + glm::vec3(s.radius);
    } else if (id >= PatchBoxBase()) {
        b = patchBoxes[id - PatchBoxBase()].bounds;
    } else {
        const Quadric& q = quadrics[id - QuadricBase()];
        b.lo = q.boxMin;
        b.hi = q.boxMax;
    }
    return b;
}

Bounds3f Scene::Bounds() const {
    Bounds3f b;
    for (uint32_t id = 0; id < PrimitiveCount(); ++id) b.Grow(PrimitiveBounds(id));
    return b;
}

Camera FramingCamera(const Bounds3f& box, uint32_t width, uint32_t height) {
    Camera c;
    c.width = width;
    c.height = height;
    c.fovYDegrees = 45.0f;
    const glm::vec3 center = box.Center();
    const glm::vec3 size = box.Size();
    const float aspect = float(width) / float(height);
    const float tanY = std::tan(glm::radians(c.fovYDegrees) * 0.5f);
    // Distance at which the box's front face fits both vertically and horizontally, plus margin.
    const float fitY = 0.5f * size.y / tanY;
    const float fitX = 0.5f * size.x / (tanY * aspect);
    const float distance = std::max({fitX, fitY, 1e-3f}) * 1.1f + 0.5f * size.z;
    c.lookAt = center;
    c.position = center + glm::vec3(0.0f, 0.0f, distance);
    c.up = glm::vec3(0.0f, 1.0f, 0.0f);
    return c;
}

}  // namespace rayclass::scene
