#include "rayclass/classify/ray5d.h"

#include <algorithm>
#include <cmath>

namespace rayclass::classify {

bool ToRay5Clipped(const Ray& ray, const Bounds3f& sceneBox, Ray5& out) {
    const glm::vec3& o = ray.origin;
    const glm::vec3& d = ray.direction;
    for (int k = 0; k < 3; ++k) {
        if (!std::isfinite(d[k]) || !std::isfinite(o[k])) return false;
    }
    const int a = DominantAxis(d);
    const float da = std::abs(d[a]);
    if (!(da > 0.0f)) return false;
    // Slab clip of the segment (tMin, tMax) against the box; an axis-parallel ray outside a slab
    // misses (its NaN or infinite slab bounds never widen the interval).
    float tEnter = ray.tMin;
    float tExit = ray.tMax;
    for (int k = 0; k < 3; ++k) {
        if (d[k] == 0.0f) {
            if (o[k] < sceneBox.lo[k] || o[k] > sceneBox.hi[k]) return false;
            continue;
        }
        const float inv = 1.0f / d[k];
        float t0 = (sceneBox.lo[k] - o[k]) * inv;
        float t1 = (sceneBox.hi[k] - o[k]) * inv;
        if (t0 > t1) std::swap(t0, t1);
        tEnter = std::max(tEnter, t0);
        tExit = std::min(tExit, t1);
    }
    if (!(tEnter <= tExit) || !(tEnter < ray.tMax)) return false;
    // The start moves to the entry point, clamped so rounding cannot put it outside.
    const glm::vec3 p = glm::clamp(o + tEnter * d, sceneBox.lo, sceneBox.hi);
    const int face = 2 * a + (d[a] < 0.0f ? 1 : 0);
    const int b = (a + 1) % 3;
    const int c = (a + 2) % 3;
    const float inv = 1.0f / da;
    out.face = face;
    out.p[0] = FaceSign(face) * p[a];
    out.p[1] = p[b];
    out.p[2] = p[c];
    out.p[3] = d[b] * inv;
    out.p[4] = d[c] * inv;
    out.reach = (tExit - tEnter) * da;
    if (!std::isfinite(out.reach)) out.reach = 3.402823466e38f;
    return true;
}

namespace {

// Where a live segment ends (finite), else false.
bool SegmentEnd(const Ray& ray, glm::vec3& end) {
    if (!(ray.tMin < ray.tMax) || !std::isfinite(ray.tMax)) return false;
    if (ray.direction == glm::vec3(0.0f)) return false;
    end = ray.origin + ray.tMax * ray.direction;
    return std::isfinite(end.x) && std::isfinite(end.y) && std::isfinite(end.z);
}

bool Near(const glm::vec3& a, const glm::vec3& b, float tolerance) {
    return std::abs(a.x - b.x) <= tolerance && std::abs(a.y - b.y) <= tolerance &&
           std::abs(a.z - b.z) <= tolerance;
}

}  // namespace

int CommonEnds::Match(const Ray& ray) const {
    glm::vec3 end;
    if (n == 0 || !SegmentEnd(ray, end)) return -1;
    for (int k = 0; k < n; ++k) {
        if (Near(end, point[size_t(k)], tolerance)) return k;
    }
    return -1;
}

Ray CommonEnds::Oriented(const Ray& ray, int match) const {
    if (match < 0) return ray;
    Ray r;
    r.origin = point[size_t(match)];
    r.tMin = 0.0f;
    r.direction = -ray.direction;
    r.tMax = ray.tMax - ray.tMin;
    return r;
}

CommonEnds FindCommonEnds(RayView rays, const Bounds3f& box, float tolerance) {
    constexpr size_t kSample = 256;
    constexpr int kSeen = 2 * CommonEnds::kMax;
    const size_t n = rays.size(), samples = std::min(n, kSample);
    // Each distinct end seen, with the range of the sampled ends near it.
    glm::vec3 first[kSeen], lo[kSeen], hi[kSeen];
    int count[kSeen] = {};
    int seen = 0, live = 0;
    for (size_t j = 0; j < samples; ++j) {
        glm::vec3 end;
        if (!SegmentEnd(rays[j * n / samples], end)) continue;
        ++live;
        int k = 0;
        while (k < seen && !Near(end, first[k], tolerance)) ++k;
        if (k == seen) {
            if (seen == kSeen) continue;
            first[k] = lo[k] = hi[k] = end;
            ++seen;
        }
        ++count[k];
        lo[k] = glm::min(lo[k], end);
        hi[k] = glm::max(hi[k], end);
    }
    CommonEnds out;
    out.tolerance = tolerance;
    int covered = 0;
    for (int k = 0; k < seen && out.n < CommonEnds::kMax; ++k) {
        if (count[k] < 2 || 32 * count[k] < live) continue;
        // The middle of the sample's ends: nearer the true point than any one of them.
        const glm::vec3 p = 0.5f * (lo[k] + hi[k]);
        if (!box.Contains(p)) continue;
        out.point[size_t(out.n++)] = p;
        covered += count[k];
    }
    out.coverSample = out.n > 0 && covered == live;
    return out;
}

}  // namespace rayclass::classify
