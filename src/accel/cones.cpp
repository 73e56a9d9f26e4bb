#include "rayclass/accel/cones.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace rayclass::accel {

namespace {

// Spreads the low 10 bits of v to every sixth bit.
uint64_t Spread6(uint32_t v) {
    uint64_t out = 0;
    for (int b = 0; b < 10; ++b) out |= uint64_t((v >> b) & 1u) << (6 * b);
    return out;
}

uint32_t Quantize(double x) { return uint32_t(std::clamp(x, 0.0, 1.0) * 1023.0); }

constexpr double kMaxHalfAngle = 89.0 * 3.14159265358979323846 / 180.0;
constexpr double kMinHalfAngle = 1e-3;
constexpr double kAngleMargin = 1e-4;

RcCone Unbounded() { return {{0.0f, 0.0f, 0.0f, -1.0f}, {0.0f, 0.0f, 1.0f, 1.0f}}; }

glm::dvec3 Origin(const RcRay& r) { return {r.origin.x, r.origin.y, r.origin.z}; }
glm::dvec3 Direction(const RcRay& r) { return {r.direction.x, r.direction.y, r.direction.z}; }

}  // namespace

std::vector<uint32_t> CoherentOrder(std::span<const RcRay> rays, const Bounds3f& box) {
    const glm::dvec3 lo(box.lo), size = glm::max(glm::dvec3(box.Size()), glm::dvec3(1e-30));
    std::vector<uint64_t> keys(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) {
        const glm::dvec3 o = (Origin(rays[i]) - lo) / size;
        const glm::dvec3 d = glm::normalize(Direction(rays[i]) + glm::dvec3(1e-300)) * 0.5 + 0.5;
        keys[i] = Spread6(Quantize(d.x)) | Spread6(Quantize(d.y)) << 1 |
                  Spread6(Quantize(d.z)) << 2 | Spread6(Quantize(o.x)) << 3 |
                  Spread6(Quantize(o.y)) << 4 | Spread6(Quantize(o.z)) << 5;
    }
    std::vector<uint32_t> order(rays.size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(),
                     [&keys](uint32_t a, uint32_t b) { return keys[a] < keys[b]; });
    return order;
}

RcCone EnclosingCone(std::span<const RcRay> rays, std::span<const uint32_t> order, size_t first,
                     size_t last, double margin) {
    glm::dvec3 x(0.0);
    double cosPhi = 1.0;
    bool any = false;
    for (size_t i = first; i < last; ++i) {
        const glm::dvec3 d = Direction(rays[order[i]]);
        if (glm::dot(d, d) == 0.0) continue;
        const glm::dvec3 r = glm::normalize(d);
        if (!any) {
            x = r;
            any = true;
            continue;
        }
        const double c = glm::dot(x, r);
        if (c >= cosPhi) continue;
        // Step (a): the smallest cone holding the old one and r.
        const glm::dvec3 qRaw = c * x - r;
        if (glm::length(qRaw) < 1e-12) {
            if (c > 0.0) continue;  // r along the axis, up to rounding
            return Unbounded();     // r opposite the axis
        }
        const glm::dvec3 q = glm::normalize(qRaw);
        const double sinPhi = std::sqrt(std::max(0.0, 1.0 - cosPhi * cosPhi));
        const glm::dvec3 e = x * cosPhi + q * sinPhi;
        // r opposite the far generator: the cone would open to 180 degrees.
        if (glm::length(e + r) < 1e-12) return Unbounded();
        x = glm::normalize(e + r);
        cosPhi = glm::dot(x, r);
        if (std::acos(std::clamp(cosPhi, -1.0, 1.0)) >= kMaxHalfAngle) return Unbounded();
    }
    if (!any) return Unbounded();
    // Every direction checked against the final axis, then the margin.
    double phi = 0.0;
    glm::dvec3 centroid(0.0);
    double count = 0;
    for (size_t i = first; i < last; ++i) {
        const glm::dvec3 d = Direction(rays[order[i]]);
        if (glm::dot(d, d) == 0.0) continue;
        phi = std::max(phi, std::acos(std::clamp(glm::dot(x, glm::normalize(d)), -1.0, 1.0)));
        centroid += Origin(rays[order[i]]);
        count += 1;
    }
    phi = std::max(phi + kAngleMargin, kMinHalfAngle);
    if (phi >= kMaxHalfAngle) return Unbounded();
    centroid /= count;
    // The apex backs off along the axis until every origin lies inside, half the margin away
    // from the surface: the apex is rounded to float, and lies far back in narrow cones.
    const double tanPhi = std::tan(phi), tanInner = std::tan(phi - 0.5 * kAngleMargin);
    double back = 0.0;
    for (size_t i = first; i < last; ++i) {
        if (glm::dot(Direction(rays[order[i]]), Direction(rays[order[i]])) == 0.0) continue;
        const glm::dvec3 c = Origin(rays[order[i]]) - centroid;
        const double along = glm::dot(c, x);
        const double across = glm::length(c - along * x);
        back = std::max(back, across / tanInner - along);
    }
    const glm::dvec3 apex = centroid - (back + margin) * x;
    return {{float(apex.x), float(apex.y), float(apex.z), float(tanPhi * tanPhi)},
            {float(x.x), float(x.y), float(x.z), float(1.0 / std::sin(phi))}};
}

PrimitiveSpheres BoundingSpheres(const scene::Scene& scene, float pad) {
    PrimitiveSpheres s;
    s.count = scene.PrimitiveCount();
    const size_t padded = (size_t(s.count) + 15) / 16 * 16;
    s.x.assign(padded, 0.0f);
    s.y.assign(padded, 0.0f);
    s.z.assign(padded, 0.0f);
    s.r.assign(padded, 0.0f);
    for (uint32_t id = 0; id < s.count; ++id) {
        glm::dvec3 c;
        double r = 0.0;
        if (id >= scene.SphereBase() && id < scene.QuadricBase()) {
            const scene::Sphere& sp = scene.spheres[id - scene.SphereBase()];
            c = glm::dvec3(sp.center);
            r = sp.radius;
        } else {
            const Bounds3f b = scene.PrimitiveBounds(id);
            c = glm::dvec3(b.Center());
            r = 0.5 * glm::length(glm::dvec3(b.hi) - glm::dvec3(b.lo));
            if (id < scene.triangles.size()) {
                // A triangle's vertices bound it tighter than its box's corners.
                r = 0.0;
                for (const glm::vec3& p : scene.triangles[id].p) {
                    r = std::max(r, glm::length(glm::dvec3(p) - c));
                }
            }
        }
        s.x[id] = float(c.x);
        s.y[id] = float(c.y);
        s.z[id] = float(c.z);
        s.r[id] = float(r * (1.0 + 1e-6)) + pad;
    }
    return s;
}

}  // namespace rayclass::accel
