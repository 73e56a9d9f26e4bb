// Rendered images: linear float RGB plus optional AOV layers, written as OpenEXR or PNG, read back
// from OpenEXR, and compared.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include <glm/glm.hpp>

namespace rayclass::image {

struct Image {
    uint32_t width = 0;
    uint32_t height = 0;
    std::vector<glm::vec3> rgb;  // row 0 at the top, linear radiance
    // AOV layers, empty when not requested. depth: distance along the eye ray to the first hit
    // (+inf on a miss); id: global primitive id of the first hit (0xFFFFFFFF on a miss); normal:
    // unit shading normal at the first hit (0 on a miss).
    std::vector<float> depth;
    std::vector<uint32_t> id;
    std::vector<glm::vec3> normal;

    Image() = default;
    Image(uint32_t w, uint32_t h) : width(w), height(h), rgb(size_t(w) * h, glm::vec3(0.0f)) {}
    size_t PixelCount() const { return size_t(width) * height; }
};

}  // namespace rayclass::image
