// Rendered images: linear float RGB plus optional AOV layers, written as OpenEXR or PNG, read back
// from OpenEXR (or PNG), and compared (see compare.h).
//
// OpenEXR channels, all full resolution (over the data window: the whole display window, or a
// crop's part of it), ZIP compressed unless WriteOptions say otherwise:
//   R, G, B                       FLOAT  linear radiance
//   depth.Z                       FLOAT  depth layer, when present
//   id.ID                         UINT   id layer, when present
//   normal.X, normal.Y, normal.Z  FLOAT  normal layer, when present
#pragma once

#include <cstdint>
#include <filesystem>
#include <glm/glm.hpp>
#include <string>
#include <vector>

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
    // Where these pixels lie in the whole image (OpenEXR's data window in its display window): a
    // crop or tile of a displayWidth x displayHeight image has its top left pixel at (originX,
    // originY). 0 x 0 stands for the image's own size.
    uint32_t originX = 0, originY = 0;
    uint32_t displayWidth = 0, displayHeight = 0;
    // What was rendered (a hash of the scene and of the options that change pixels), so that
    // tiles of different renders are not merged; OpenEXR keeps it in the header attribute
    // "rayclassSceneHash". Empty: unknown.
    std::string sceneHash;

    Image() = default;
    Image(uint32_t w, uint32_t h) : width(w), height(h), rgb(size_t(w) * h, glm::vec3(0.0f)) {}
    size_t PixelCount() const { return size_t(width) * height; }
    uint32_t DisplayWidth() const { return displayWidth ? displayWidth : width; }
    uint32_t DisplayHeight() const { return displayHeight ? displayHeight : height; }
};

// Lossless OpenEXR compressions. Float radiance compresses poorly: ZIP and PIZ save a little
// space for a write that can take longer than a small render (ZIP at zlib's fastest level), and
// kNone writes at memory speed.
enum class ExrCompression { kZip, kPiz, kNone };

// PNG's zlib settings. kSmall is libpng's defaults (level 6, each row's filter chosen among all
// five): the smallest file, and the slowest to write. kFast, run-length deflate of up-filtered
// rows, writes several times faster for a file about a quarter larger; kNone stores the rows.
enum class PngCompression { kFast, kSmall, kNone };

struct WriteOptions {
    // PNG only: radiance is scaled by 2^exposure before it is clamped to [0, 1] and encoded with
    // the sRGB transfer function (rounded to the nearest 8-bit value). OpenEXR keeps raw radiance.
    float exposure = 0.0f;
    ExrCompression exrCompression = ExrCompression::kZip;   // OpenEXR only
    PngCompression pngCompression = PngCompression::kFast;  // PNG only
};

// Writes `image` to `out` as OpenEXR (".exr") or 8-bit sRGB PNG (".png"), chosen by the extension
// (case-insensitive). The data goes to a temporary file beside `out` that is then renamed over
// it, so a failed write leaves neither a partial file nor a damaged previous one. Throws
// rayclass::Error naming `out` and the reason (unsupported extension, OS error, an empty image,
// layer sizes that do not match width x height).
void WriteImage(const Image& image, const std::filesystem::path& out,
                const WriteOptions& options = {});

// Reads an OpenEXR file (recognised by content, not extension): R, G, B are required (half or
// float, alpha ignored), the depth/id/normal layers above are read when present. Also reads PNG,
// converting sRGB to linear radiance (no exposure is undone). Throws rayclass::Error naming `file`
// when it is missing, unreadable or not such an image.
Image ReadImage(const std::filesystem::path& file);

}  // namespace rayclass::image
