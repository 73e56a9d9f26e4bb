#include "rayclass/classify/params.h"

#include <algorithm>

namespace rayclass::classify {

Params Params::ForScene(const scene::Scene& scene) {
    Params p;
    const Bounds3f box = scene.Bounds();
    // Scaled by the larger of the diagonal and the largest coordinate, so that a scene far from
    // the origin still pads by many ulps; a scene of one point still gets a box with volume.
    float scale = 1.0f;
    if (!box.Empty()) {
        const glm::vec3 m = glm::max(glm::abs(box.lo), glm::abs(box.hi));
        scale = std::max({box.Diagonal(), m.x, m.y, m.z, 1e-6f});
    }
    p.padding = 2e-6f * scale;
    return p;
}

}  // namespace rayclass::classify
