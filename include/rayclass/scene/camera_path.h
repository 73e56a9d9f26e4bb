// A camera path for animations: keyframes of the camera's position and look-at point at given
// times, between them linear or Catmull-Rom interpolation; frame K lies at time t0 + K / fps.
#pragma once

#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

namespace rayclass::scene {

struct Camera;

struct Keyframe {
    double time = 0;
    glm::vec3 position{0.0f};
    glm::vec3 lookAt{0.0f};
};

enum class Interpolation : uint8_t { kLinear, kCatmullRom };

struct CameraPath {
    Interpolation interpolation = Interpolation::kLinear;
    double fps = 24;
    std::vector<Keyframe> keyframes;  // times strictly increasing; none: no path

    bool Empty() const { return keyframes.empty(); }
    // Time of frame `frame`.
    double TimeOf(uint32_t frame) const { return keyframes.front().time + frame / fps; }
    // The frames whose time lies on the path: [0, FrameCount()).
    uint32_t FrameCount() const;
    // `base` (its up vector, field of view and size) moved to frame `frame`'s place on the path.
    // Throws rayclass::Error when the frame lies past the last keyframe or its look-at point
    // falls on its position.
    Camera At(const Camera& base, uint32_t frame) const;
};

}  // namespace rayclass::scene
