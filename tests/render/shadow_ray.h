// Shadow rays as the shading kernels spawn them, for the render module's suites.
#pragma once

#include <glm/glm.hpp>

#include "rc_types.h"

namespace rayclass::render {

// The shadow ray from `origin` toward `light`: tmin 0, a unit direction, tmax the distance.
inline RcRay ShadowRay(const glm::vec3& origin, const glm::vec3& light) {
    const glm::vec3 to = light - origin;
    const float dist = glm::length(to);
    const glm::vec3 d = to / dist;
    return {{origin.x, origin.y, origin.z, 0.0f}, {d.x, d.y, d.z, dist}};
}

}  // namespace rayclass::render
