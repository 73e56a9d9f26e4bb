#include "rayclass/scene/camera_path.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "rayclass/core/error.h"
#include "rayclass/scene/scene.h"

namespace rayclass::scene {

namespace {

// Uniform Catmull-Rom between p1 and p2 at u in [0, 1], p0 and p3 their neighbours.
glm::dvec3 CatmullRom(const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& p2,
                      const glm::dvec3& p3, double u) {
    const double u2 = u * u, u3 = u2 * u;
    return 0.5 * ((2.0 * p1) + (p2 - p0) * u + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * u2 +
                  (3.0 * p1 - p0 - 3.0 * p2 + p3) * u3);
}

}  // namespace

uint32_t CameraPath::FrameCount() const {
    if (Empty()) return 0;
    const double span = keyframes.back().time - keyframes.front().time;
    return uint32_t(std::floor(span * fps + 1e-9)) + 1;
}

Camera CameraPath::At(const Camera& base, uint32_t frame) const {
    const double t = TimeOf(frame);
    if (frame >= FrameCount()) {
        throw Error("frame " + std::to_string(frame) + " (time " + std::to_string(t) +
                    ") lies past the camera path's last keyframe (time " +
                    std::to_string(keyframes.back().time) + "; frames 0.." +
                    std::to_string(FrameCount() - 1) + ")");
    }
    // Segment [i, i + 1] holds t (the last one also its end).
    size_t i = 0;
    while (i + 2 < keyframes.size() && keyframes[i + 1].time <= t) ++i;
    const Keyframe &a = keyframes[i], &b = keyframes[std::min(i + 1, keyframes.size() - 1)];
    const double u = b.time > a.time ? std::clamp((t - a.time) / (b.time - a.time), 0.0, 1.0) : 0.0;
    auto interpolate = [&](glm::vec3 Keyframe::*field) {
        const glm::dvec3 p1(a.*field), p2(b.*field);
        if (interpolation == Interpolation::kLinear) return glm::vec3(p1 + (p2 - p1) * u);
        const glm::dvec3 p0 = i > 0 ? glm::dvec3(keyframes[i - 1].*field) : p1;
        const glm::dvec3 p3 = i + 2 < keyframes.size() ? glm::dvec3(keyframes[i + 2].*field) : p2;
        return glm::vec3(CatmullRom(p0, p1, p2, p3, u));
    };
    Camera c = base;
    c.position = interpolate(&Keyframe::position);
    c.lookAt = interpolate(&Keyframe::lookAt);
    const glm::vec3 view = c.lookAt - c.position;
    if (glm::length(view) == 0.0f || glm::length(glm::cross(view, c.up)) == 0.0f) {
        throw Error("frame " + std::to_string(frame) +
                    ": the camera path's look-at point meets its position or lies along 'up'");
    }
    return c;
}

}  // namespace rayclass::scene
