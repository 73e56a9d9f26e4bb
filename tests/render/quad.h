// Test geometry shared by the render module's suites.
#pragma once

#include "rayclass/scene/scene.h"

namespace rayclass::render {

// The quad a b c d (corners in order around it) as two triangles, split along a-c.
inline void AddQuad(scene::Scene& s, glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d) {
    scene::Triangle t;
    t.p = {a, b, c};
    s.triangles.push_back(t);
    t.p = {a, c, d};
    s.triangles.push_back(t);
}

}  // namespace rayclass::render
