#include "rayclass/accel/triangle_box.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace rayclass::accel {

namespace {

// The polygon's part on the side `sign` * (p[axis] - plane) <= 0.
void ClipPolygon(std::vector<glm::dvec3>& poly, std::vector<glm::dvec3>& out, int axis,
                 double plane, double sign) {
    out.clear();
    const size_t n = poly.size();
    for (size_t i = 0; i < n; ++i) {
        const glm::dvec3& a = poly[i];
        const glm::dvec3& b = poly[(i + 1) % n];
        const double da = sign * (a[axis] - plane), db = sign * (b[axis] - plane);
        if (da <= 0) out.push_back(a);
        if ((da < 0 && db > 0) || (da > 0 && db < 0)) {
            glm::dvec3 p = a + (b - a) * (da / (da - db));
            p[axis] = plane;  // exactly on the plane, whatever the division rounded
            out.push_back(p);
        }
    }
    poly.swap(out);
}

// Whether the projections of the triangle and of the box (centre c, half size h) on `axis` are
// disjoint.
bool Separates(const glm::dvec3& axis, const Triangle3d& t, const glm::dvec3& h) {
    const double p0 = glm::dot(axis, t[0]), p1 = glm::dot(axis, t[1]), p2 = glm::dot(axis, t[2]);
    const double r = h.x * std::abs(axis.x) + h.y * std::abs(axis.y) + h.z * std::abs(axis.z);
    return std::min({p0, p1, p2}) > r || std::max({p0, p1, p2}) < -r;
}

}  // namespace

Bounds3d ClipTriangle(const Triangle3d& tri, const Bounds3d& box) {
    Bounds3d triBox;
    for (const glm::dvec3& p : tri) triBox.Grow(p);
    const Bounds3d overlap = Intersection(triBox, box);
    if (overlap.Empty()) return overlap;
    // A triangle inside the box on every axis needs no clipping.
    if (overlap.lo == triBox.lo && overlap.hi == triBox.hi) return triBox;
    std::vector<glm::dvec3> poly(tri.begin(), tri.end()), scratch;
    poly.reserve(9);
    scratch.reserve(9);
    for (int axis = 0; axis < 3 && !poly.empty(); ++axis) {
        ClipPolygon(poly, scratch, axis, box.lo[axis], -1.0);
        if (!poly.empty()) ClipPolygon(poly, scratch, axis, box.hi[axis], 1.0);
    }
    Bounds3d out;
    for (const glm::dvec3& p : poly) out.Grow(p);
    return Intersection(out, box);
}

bool TriangleOverlapsBox(const Triangle3d& tri, const Bounds3d& box) {
    const glm::dvec3 c = box.Center(), h = (box.hi - box.lo) * 0.5;
    const Triangle3d t = {tri[0] - c, tri[1] - c, tri[2] - c};
    const glm::dvec3 e[3] = {t[1] - t[0], t[2] - t[1], t[0] - t[2]};
    const glm::dvec3 unit[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    // The box's face normals, the triangle's normal, and the nine edge cross products; a zero
    // axis (parallel or degenerate edges) separates nothing.
    for (const glm::dvec3& u : unit) {
        if (Separates(u, t, h)) return false;
    }
    if (Separates(glm::cross(e[0], e[1]), t, h)) return false;
    for (const glm::dvec3& u : unit) {
        for (const glm::dvec3& edge : e) {
            if (Separates(glm::cross(u, edge), t, h)) return false;
        }
    }
    return true;
}

Triangle3d TriangleOf(const scene::Scene& scene, uint32_t id) {
    const auto& p = scene.triangles[id].p;
    return {glm::dvec3(p[0]), glm::dvec3(p[1]), glm::dvec3(p[2])};
}

Bounds3d PrimitiveExtentIn(const scene::Scene& scene, uint32_t id, const Bounds3d& box) {
    if (id < scene.triangles.size()) return ClipTriangle(TriangleOf(scene, id), box);
    const Bounds3f b = scene.PrimitiveBounds(id);
    return Intersection({glm::dvec3(b.lo), glm::dvec3(b.hi)}, box);
}

}  // namespace rayclass::accel
