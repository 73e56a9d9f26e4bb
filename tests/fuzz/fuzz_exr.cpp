// libFuzzer target: image::ReadImage (the OpenEXR and PNG readers behind `rayclass compare`) on
// the input written to a file, since the readers take a path. Only rayclass::Error may leave the
// reader; anything else (another exception, a crash, a sanitizer report) is a finding. An image
// that loads must have layers of width x height pixels.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "rayclass/core/error.h"
#include "rayclass/image/image.h"

namespace {

std::filesystem::path InputPath() {
    static const std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("rayclass-fuzz-exr-" + std::to_string(getpid()));
    return path;
}

void WriteInput(const uint8_t* data, size_t size) {
    std::FILE* f = std::fopen(InputPath().c_str(), "wb");
    if (!f) std::abort();
    if (size && std::fwrite(data, 1, size, f) != size) std::abort();
    if (std::fclose(f) != 0) std::abort();
}

void CheckLayers(const rayclass::image::Image& image) {
    const size_t pixels = image.PixelCount();
    if (image.rgb.size() != pixels) std::abort();
    if (!image.depth.empty() && image.depth.size() != pixels) std::abort();
    if (!image.id.empty() && image.id.size() != pixels) std::abort();
    if (!image.normal.empty() && image.normal.size() != pixels) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    WriteInput(data, size);
    try {
        CheckLayers(rayclass::image::ReadImage(InputPath()));
    } catch (const rayclass::Error&) {
    }
    return 0;
}
