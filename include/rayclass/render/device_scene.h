// The scene in the flat layouts of cl/shared/rc_types.h, as the device reads it.
#pragma once

#include <optional>
#include <vector>

#include "rayclass/image/image.h"
#include "rayclass/image/tiles.h"
#include "rayclass/scene/scene.h"
#include "rc_types.h"

namespace rayclass::render {

// Camera basis in double; every eye-ray path derives its rays from this one basis. A render
// covers its window of the width x height image (see RcCamera): all of it, or a crop.
struct CameraBasis {
    glm::dvec3 position, forward, right, up;
    double tanHalfFovX = 1, tanHalfFovY = 1;
    uint32_t width = 1, height = 1;
    image::PixelRect window;

    // Throws rayclass::Error when `window` is empty or reaches outside the image.
    explicit CameraBasis(const scene::Camera& camera,
                         const std::optional<image::PixelRect>& window = std::nullopt);
    // The eye ray of pixel (x, y) in double: see RcCamera.
    glm::dvec3 Direction(uint32_t x, uint32_t y) const;
    // The same ray in float from ToDevice()'s values, the arithmetic of cl/camera.cl, for host
    // code that must shoot the rays the kernels shoot (statistics, benchmarks).
    glm::vec3 DirectionFloat(uint32_t x, uint32_t y) const;
    RcCamera ToDevice() const;
};

// The image a render of `basis` fills: its window's pixels, placed in the whole image, black, and
// with `aovs` the first-hit layers of misses.
image::Image NewImage(const CameraBasis& basis, bool aovs);

// One primitive, material or light as the kernels read it.
RcTriangle ToDevice(const scene::Triangle& t);
RcTriangleShading ShadingOf(const scene::Triangle& t);
RcSphere ToDevice(const scene::Sphere& s);
RcQuadric ToDevice(const scene::Quadric& q);
RcMaterial ToDevice(const scene::Material& m);
RcLight ToDevice(const scene::PointLight& l);

// ToDevice as one callable, for any element type.
inline constexpr auto kToDevice = [](const auto& x) { return ToDevice(x); };

// convert(item) for each of `items`, in a host array (the raster pass's storage buffers;
// SceneBuffers writes the device buffers in place instead).
template <typename Items, typename F = decltype(kToDevice)>
auto DeviceArray(const Items& items, F convert = kToDevice) {
    std::vector<decltype(convert(items[0]))> out;
    out.reserve(items.size());
    for (const auto& item : items) out.push_back(convert(item));
    return out;
}

}  // namespace rayclass::render
