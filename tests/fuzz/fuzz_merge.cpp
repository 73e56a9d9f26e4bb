// libFuzzer target: `rayclass merge`'s path, image::ReadImage on each tile file and
// image::MergeTiles on the tiles. The input is a flag byte (bit 0: --allow-partial) and then up
// to kMaxTiles tile files separated by kSeparator; the seeds are tiles of small renders, so the
// mutations reach the headers' display and data windows, the layers and the scene hash. Only
// rayclass::Error may leave the reader or the merge; anything else (another exception, a crash,
// a sanitizer report) is a finding. A merged image must hold every tile's pixels, in every
// layer, bit for bit at its place; without --allow-partial the tiles' areas must add up to the
// whole image. Merges into images over kMaxMergedPixels are not run: a one-tile header may name
// any display window up to ReadImage's 16384 pixels a side, and --allow-partial then makes a
// black image that large (8.6 GB with every layer), as a render of that size would, beyond the
// fuzzer's memory limit.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "rayclass/core/error.h"
#include "rayclass/image/image.h"
#include "rayclass/image/merge.h"

namespace {

namespace image = rayclass::image;

constexpr std::string_view kSeparator = "RCTILE";
constexpr size_t kMaxTiles = 4;
constexpr size_t kMaxMergedPixels = size_t(1) << 22;

std::filesystem::path TilePath(size_t k) {
    return std::filesystem::temp_directory_path() /
           ("rayclass-fuzz-merge-" + std::to_string(getpid()) + "-" + std::to_string(k));
}

void WriteFile(const std::filesystem::path& path, std::string_view bytes) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) std::abort();
    if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), f) != bytes.size()) {
        std::abort();
    }
    if (std::fclose(f) != 0) std::abort();
}

// The tile files: split at the separator, the last one taking the rest.
std::vector<std::string_view> Split(std::string_view rest) {
    std::vector<std::string_view> parts;
    while (parts.size() + 1 < kMaxTiles) {
        const size_t at = rest.find(kSeparator);
        if (at == std::string_view::npos) break;
        parts.push_back(rest.substr(0, at));
        rest.remove_prefix(at + kSeparator.size());
    }
    parts.push_back(rest);
    return parts;
}

template <typename T>
void CheckLayer(const std::vector<T>& tile, const image::Image& t, const std::vector<T>& whole,
                uint32_t width) {
    if (tile.empty() != whole.empty()) std::abort();
    if (tile.empty()) return;
    if (tile.size() != t.PixelCount() || whole.size() % width != 0) std::abort();
    for (uint32_t y = 0; y < t.height; ++y) {
        const size_t at = size_t(t.originY + y) * width + t.originX;
        if (at + t.width > whole.size()) std::abort();
        if (std::memcmp(&tile[size_t(y) * t.width], &whole[at], t.width * sizeof(T)) != 0) {
            std::abort();
        }
    }
}

void CheckMerged(const std::vector<image::NamedTile>& tiles, const image::Image& whole,
                 bool allowPartial) {
    const image::Image& first = tiles.front().image;
    if (whole.width != first.DisplayWidth() || whole.height != first.DisplayHeight()) {
        std::abort();
    }
    if (whole.rgb.size() != whole.PixelCount() || whole.sceneHash != first.sceneHash) {
        std::abort();
    }
    size_t area = 0;
    for (const image::NamedTile& t : tiles) {
        CheckLayer(t.image.rgb, t.image, whole.rgb, whole.width);
        CheckLayer(t.image.depth, t.image, whole.depth, whole.width);
        CheckLayer(t.image.id, t.image, whole.id, whole.width);
        CheckLayer(t.image.normal, t.image, whole.normal, whole.width);
        area += t.image.PixelCount();
    }
    if (area > whole.PixelCount() || (!allowPartial && area != whole.PixelCount())) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    if (size == 0) return 0;
    const bool allowPartial = data[0] & 1;
    const std::vector<std::string_view> parts =
        Split(std::string_view(reinterpret_cast<const char*>(data) + 1, size - 1));
    std::vector<image::NamedTile> tiles;
    try {
        for (size_t k = 0; k < parts.size(); ++k) {
            WriteFile(TilePath(k), parts[k]);
            tiles.push_back({TilePath(k).string(), image::ReadImage(TilePath(k))});
        }
    } catch (const rayclass::Error&) {
        return 0;
    }
    const image::Image& first = tiles.front().image;
    if (size_t(first.DisplayWidth()) * first.DisplayHeight() > kMaxMergedPixels) return 0;
    try {
        CheckMerged(tiles, image::MergeTiles(tiles, allowPartial), allowPartial);
    } catch (const rayclass::Error&) {
    }
    return 0;
}
