#include "rayclass/scene/tessellate.h"

#include "rayclass/geometry/patch_intersect.h"

namespace rayclass::scene {

namespace {

struct Vertex {
    glm::vec3 p, n;
};

bool Degenerate(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
    const glm::vec3 n = glm::cross(b - a, c - a);
    return !(glm::dot(n, n) > 0.0f);
}

}  // namespace

std::vector<Triangle> TessellatePatch(const Patch& patch, uint32_t n) {
    std::vector<Vertex> grid;
    grid.reserve(size_t(n + 1) * (n + 1));
    for (uint32_t i = 0; i <= n; ++i) {
        for (uint32_t j = 0; j <= n; ++j) {
            glm::dvec3 p;
            const glm::dvec3 normal =
                geometry::PatchNormal(patch.p, double(i) / n, double(j) / n, &p);
            const double length = glm::length(normal);
            grid.push_back({glm::vec3(p), length > 0 ? glm::vec3(normal / length) : glm::vec3(0)});
        }
    }
    auto at = [&](uint32_t i, uint32_t j) -> const Vertex& { return grid[i * (n + 1) + j]; };
    std::vector<Triangle> out;
    auto add = [&](const Vertex& a, const Vertex& b, const Vertex& c) {
        if (Degenerate(a.p, b.p, c.p)) return;
        Triangle t;
        t.p = {a.p, b.p, c.p};
        t.n = {a.n, b.n, c.n};
        // A normal lost where the patch degenerates: the triangle is shaded flat instead.
        t.hasNormals = glm::dot(a.n, a.n) > 0 && glm::dot(b.n, b.n) > 0 && glm::dot(c.n, c.n) > 0;
        t.material = patch.material;
        t.object = patch.object;
        out.push_back(t);
    };
    for (uint32_t i = 0; i < n; ++i) {
        for (uint32_t j = 0; j < n; ++j) {
            add(at(i, j), at(i + 1, j), at(i + 1, j + 1));
            add(at(i, j), at(i + 1, j + 1), at(i, j + 1));
        }
    }
    return out;
}

}  // namespace rayclass::scene
