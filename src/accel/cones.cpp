#include "rayclass/accel/cones.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

namespace rayclass::accel {

namespace {

// The low 10 bits of v spread to every sixth bit, for every v.
const std::array<uint64_t, 1024>& Spread6Table() {
    static const std::array<uint64_t, 1024> table = [] {
        std::array<uint64_t, 1024> t{};
        for (uint32_t v = 0; v < 1024; ++v) {
            for (int b = 0; b < 10; ++b) t[v] |= uint64_t((v >> b) & 1u) << (6 * b);
        }
        return t;
    }();
    return table;
}

// The indices 0 .. n-1 ordered by keys, equal keys by index: least significant digit first,
// 16 bits a pass, passes over a digit every key shares skipped.
std::vector<uint32_t> RadixOrder(const std::vector<uint64_t>& keys) {
    const size_t n = keys.size();
    std::vector<uint32_t> order(n), next(n);
    std::iota(order.begin(), order.end(), 0u);
    for (int shift = 0; shift < 64; shift += 16) {
        std::vector<uint32_t> start(65537, 0);
        for (uint64_t k : keys) ++start[((k >> shift) & 0xFFFF) + 1];
        if (n == 0 || start[((keys[0] >> shift) & 0xFFFF) + 1] == n) continue;
        for (size_t b = 1; b < start.size(); ++b) start[b] += start[b - 1];
        for (uint32_t i : order) next[start[(keys[i] >> shift) & 0xFFFF]++] = i;
        order.swap(next);
    }
    return order;
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
    const std::array<uint64_t, 1024>& spread = Spread6Table();
    std::vector<uint64_t> keys(rays.size());
    for (size_t i = 0; i < rays.size(); ++i) {
        const glm::dvec3 o = (Origin(rays[i]) - lo) / size;
        const glm::dvec3 d = glm::normalize(Direction(rays[i]) + glm::dvec3(1e-300)) * 0.5 + 0.5;
        keys[i] = spread[Quantize(d.x)] | spread[Quantize(d.y)] << 1 | spread[Quantize(d.z)] << 2 |
                  spread[Quantize(o.x)] << 3 | spread[Quantize(o.y)] << 4 |
                  spread[Quantize(o.z)] << 5;
    }
    return RadixOrder(keys);
}

namespace {

// The paper's step (a): the smallest cone with the same apex holding the cone (axis *x, cosine
// of the half-angle *cosPhi) and the unit direction r. False when that cone would open to 180
// degrees or beyond kMaxHalfAngle.
bool WidenToDirection(glm::dvec3* x, double* cosPhi, const glm::dvec3& r) {
    const double c = glm::dot(*x, r);
    if (c >= *cosPhi) return true;
    const glm::dvec3 qRaw = c * *x - r;
    if (glm::length(qRaw) < 1e-12)
        return c > 0.0;  // r along the axis (up to rounding), or opposite
    const glm::dvec3 q = glm::normalize(qRaw);
    const double sinPhi = std::sqrt(std::max(0.0, 1.0 - *cosPhi * *cosPhi));
    const glm::dvec3 e = *x * *cosPhi + q * sinPhi;
    // r opposite the far generator: the cone would open to 180 degrees.
    if (glm::length(e + r) < 1e-12) return false;
    *x = glm::normalize(e + r);
    *cosPhi = glm::dot(*x, r);
    return *cosPhi > std::cos(kMaxHalfAngle);  // acos(*cosPhi) < kMaxHalfAngle
}

// The paper's step (b): where p lies outside the cone (apex *a, axis x, half-angle with cosine
// cosPhi), the apex slides back along the far generator e until the near generator n passes
// through p: with c = p - a and g = c - (n.c) n, by |g|^2 / -(e.g) (the printed rule has the
// sign the other way, which moves the apex forward). Where p lies behind the apex beyond the
// far generator (e.g >= 0) no slide along e reaches it, and the apex backs off along the axis
// instead until p lies on the cone; either move keeps every point the old cone held.
void WidenToOrigin(glm::dvec3* a, const glm::dvec3& x, double cosPhi, const glm::dvec3& p) {
    const glm::dvec3 c = p - *a;
    const double along = glm::dot(x, c);
    const glm::dvec3 qRaw = along * x - c;  // away from p, across the axis
    const double across = glm::length(qRaw);
    if (along >= 0.0 && across <= along * std::sqrt(1.0 - cosPhi * cosPhi) / cosPhi) return;
    const double sinPhi = std::sqrt(std::max(0.0, 1.0 - cosPhi * cosPhi));
    if (across > 1e-12 * glm::length(c)) {
        const glm::dvec3 q = qRaw / across;
        const glm::dvec3 e = x * cosPhi + q * sinPhi, n = x * cosPhi - q * sinPhi;
        const glm::dvec3 g = c - glm::dot(n, c) * n;
        const double eg = glm::dot(e, g);
        if (eg < 0.0) {
            *a -= e * (glm::dot(g, g) / -eg);
            return;
        }
    }
    *a -= x * (across * cosPhi / sinPhi - along);
}

}  // namespace

RcCone EnclosingCone(std::span<const RcRay> rays, double margin) {
    // The incremental construction, steps (a) and (b) for each ray in turn, from the narrowest
    // cone the kernels take (kMinHalfAngle: a cone of angle 0 cannot take an origin off its
    // axis).
    glm::dvec3 x(0.0), a(0.0);
    double cosPhi = std::cos(kMinHalfAngle);
    bool any = false;
    for (const RcRay& ray : rays) {
        const glm::dvec3 d = Direction(ray);
        if (glm::dot(d, d) == 0.0) continue;
        const glm::dvec3 r = glm::normalize(d), p = Origin(ray);
        if (!any) {
            x = r;
            a = p;
            any = true;
            continue;
        }
        if (!WidenToDirection(&x, &cosPhi, r)) return Unbounded();
        WidenToOrigin(&a, x, cosPhi, p);
    }
    if (!any) return Unbounded();
    // Every direction checked against the final axis, then the margin for the kernels' float
    // arithmetic (acos is decreasing: the widest direction has the smallest cosine).
    double minCos = 1.0;
    for (const RcRay& ray : rays) {
        const glm::dvec3 d = Direction(ray);
        if (glm::dot(d, d) == 0.0) continue;
        minCos = std::min(minCos, glm::dot(x, glm::normalize(d)));
    }
    const double phi =
        std::max(std::acos(std::clamp(minCos, -1.0, 1.0)) + kAngleMargin, kMinHalfAngle);
    if (phi >= kMaxHalfAngle) return Unbounded();
    // Every origin checked too: where rounding left one outside, the apex backs off along the
    // axis until it lies inside, half the margin away from the surface (the apex is rounded to
    // float, and lies far back in narrow cones).
    const double tanPhi = std::tan(phi), tanInner = std::tan(phi - 0.5 * kAngleMargin);
    double back = 0.0;
    for (const RcRay& ray : rays) {
        if (glm::dot(Direction(ray), Direction(ray)) == 0.0) continue;
        const glm::dvec3 c = Origin(ray) - a;
        const double along = glm::dot(c, x);
        const double across = glm::length(c - along * x);
        back = std::max(back, across / tanInner - along);
    }
    const glm::dvec3 apex = a - (back + margin) * x;
    return {{float(apex.x), float(apex.y), float(apex.z), float(tanPhi * tanPhi)},
            {float(x.x), float(x.y), float(x.z), float(1.0 / std::sin(phi))}};
}

bool CoherentAsGiven(std::span<const RcRay> rays) {
    constexpr size_t kSampleEvery = 16;  // tiles
    constexpr double kMeanHalfAngle = 0.05;
    double sum = 0.0;
    size_t sampled = 0;
    for (size_t first = 0; first < rays.size(); first += kSampleEvery * kConeTileRays) {
        const RcCone c = EnclosingCone(
            rays.subspan(first, std::min<size_t>(kConeTileRays, rays.size() - first)), 0.0);
        if (c.apex.w < 0.0f) return false;
        sum += std::atan(std::sqrt(double(c.apex.w)));
        ++sampled;
    }
    return sampled > 0 && sum <= kMeanHalfAngle * double(sampled);
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
